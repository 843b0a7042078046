//! Progress, behind the integrators' `Progress` trait: an indicatif bar on a terminal, and where
//! standard error is not a terminal (a cluster job's log) a line every few seconds with what is
//! done, the time elapsed and an estimate of the time remaining.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lightlab_core::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Seconds between progress lines when not on a terminal; `LIGHTLAB_PROGRESS_SECONDS` overrides it.
const LINE_INTERVAL: f64 = 10.0;

pub struct Bar {
    pub bar: ProgressBar,
    lines: Option<Lines>,
}

/// Progress written as log lines.
struct Lines {
    label: String,
    /// How the line counts.
    unit: Unit,
    interval: Duration,
    total: AtomicU64,
    done: AtomicU64,
    /// Whether the work began: a report of work that never began (a cached reference) writes
    /// nothing.
    started: AtomicBool,
    /// When the job started and when the last line was written.
    times: Mutex<(Instant, Instant)>,
}

/// How a line reports the count.
#[derive(Clone, Copy)]
pub enum Unit {
    /// "12/180 runs".
    Count(&'static str),
    /// "45 %".
    Percent,
}

impl Bar {
    /// A progress report named `message`, counting in `unit`. On a terminal the bar appears when
    /// the work starts (or when a `MultiProgress` it is added to draws it), so work that turns out
    /// to be done already (a cached reference) shows no empty bar.
    pub fn new(message: &str, unit: Unit) -> Bar {
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::hidden());
            bar.set_style(
                ProgressStyle::with_template(
                    "{msg} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            bar.set_message(message.to_string());
            return Bar { bar, lines: None };
        }
        let interval = std::env::var("LIGHTLAB_PROGRESS_SECONDS")
            .ok()
            .and_then(|s| s.parse::<f64>().ok())
            .filter(|s| *s >= 0.0 && s.is_finite())
            .unwrap_or(LINE_INTERVAL);
        let now = Instant::now();
        Bar {
            bar: ProgressBar::hidden(),
            lines: Some(Lines {
                label: message.trim().to_string(),
                unit,
                interval: Duration::from_secs_f64(interval),
                total: AtomicU64::new(0),
                done: AtomicU64::new(0),
                started: AtomicBool::new(false),
                times: Mutex::new((now, now)),
            }),
        }
    }

    /// Ends the report: clears the bar, or writes the last line.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
        if let Some(l) = &self.lines
            && l.started.load(Ordering::Relaxed)
        {
            l.write(true);
        }
    }
}

impl Lines {
    /// Writes a line if the interval has passed (or `force`).
    fn write(&self, force: bool) {
        let (total, done) = (
            self.total.load(Ordering::Relaxed),
            self.done.load(Ordering::Relaxed),
        );
        let Ok(mut times) = self.times.lock() else {
            return;
        };
        let now = Instant::now();
        if !force && now.duration_since(times.1) < self.interval {
            return;
        }
        times.1 = now;
        let elapsed = now.duration_since(times.0).as_secs_f64();
        let fraction = if total > 0 {
            (done as f64 / total as f64).min(1.0)
        } else {
            0.0
        };
        let remaining = if fraction > 0.0 {
            clock(elapsed * (1.0 - fraction) / fraction)
        } else {
            "unknown".into()
        };
        let count = match self.unit {
            Unit::Count(what) => format!("{done}/{total} {what} ({:.1} %)", 100.0 * fraction),
            Unit::Percent => format!("{:.0} %", 100.0 * fraction),
        };
        eprintln!(
            "{}: {count}, elapsed {}, remaining ≈ {remaining}",
            self.label,
            clock(elapsed)
        );
    }
}

/// h:mm:ss.
fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

impl Progress for Bar {
    fn start(&self, total: u64) {
        if self.lines.is_none() && self.bar.is_hidden() {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        self.bar.set_length(total);
        self.bar.set_position(0);
        if let Some(l) = &self.lines {
            l.total.store(total, Ordering::Relaxed);
            l.done.store(0, Ordering::Relaxed);
            l.started.store(true, Ordering::Relaxed);
        }
    }
    fn advance(&self, n: u64) {
        self.bar.inc(n);
        if let Some(l) = &self.lines {
            l.done.fetch_add(n, Ordering::Relaxed);
            l.write(false);
        }
    }
}
