//! Wall and CPU time for the benchmarks (BENCHMARKS.md reports both: per-CPU-second rates compare
//! single- and multi-threaded runs fairly, wall-clock rates show the speed-up).

use std::time::Instant;

/// Process CPU time (user + system, all threads) in seconds, from /proc/self/stat fields 14 and 15
/// (clock ticks of 1/100 s, so time runs of at least a few seconds).
pub fn cpu_seconds() -> f64 {
    try_cpu_seconds().expect("/proc/self/stat is readable and has fields 14 and 15")
}

/// [`cpu_seconds`], or `None` where /proc/self/stat is missing or unreadable (not Linux).
pub fn try_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after_name = stat.get(stat.rfind(')')? + 2..)?;
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    // `fields[0]` is field 3 (state), so fields 14 and 15 are at 11 and 12.
    let ticks = fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

/// The result of `f` with the wall and CPU seconds it took.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
    let (wall, cpu) = (Instant::now(), cpu_seconds());
    let out = f();
    (out, wall.elapsed().as_secs_f64(), cpu_seconds() - cpu)
}

/// The CPU's model name (the first "model name" of /proc/cpuinfo), or `None` where there is no such
/// line (not Linux, or an architecture that names it otherwise). Speed ratios against another
/// renderer depend on it: a JIT that compiles for the host's vector width gains more from AVX-512.
pub fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, name)| name.trim().to_string())
}

/// The widest SIMD instruction set this build may use, fixed when it was compiled (`-C target-cpu`
/// or `-C target-feature`: `.cargo/config.toml` builds for the building machine's CPU, the portable
/// x86-64 target allows SSE2 only). Speed figures hold for one build as they do for one machine: on
/// this project's machines an AVX-512 or AVX2 build renders 2–10 % faster than the portable one
/// (README, "Speed and the build").
pub fn build_simd() -> &'static str {
    if cfg!(target_feature = "avx512f") {
        "AVX-512"
    } else if cfg!(target_feature = "avx2") {
        "AVX2"
    } else if cfg!(target_feature = "avx") {
        "AVX"
    } else if cfg!(target_feature = "sse4.2") {
        "SSE4.2"
    } else if cfg!(target_feature = "sse2") {
        "SSE2"
    } else if cfg!(target_feature = "neon") {
        "NEON"
    } else {
        "none"
    }
}

/// Peak resident memory of the process in bytes (VmHWM of /proc/self/status).
pub fn peak_rss_bytes() -> u64 {
    let status =
        std::fs::read_to_string("/proc/self/status").expect("/proc/self/status is readable");
    let line = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .expect("VmHWM in /proc/self/status");
    let kib: u64 = line
        .split_whitespace()
        .nth(1)
        .and_then(|v| v.parse().ok())
        .expect("VmHWM value in kB");
    kib * 1024
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_grows_with_work() {
        let (x, wall, cpu) = timed(|| {
            let mut x = 0u64;
            let start = Instant::now();
            while start.elapsed().as_secs_f64() < 0.3 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
            }
            x
        });
        assert!(x != 0 && wall >= 0.3);
        // Busy for 0.3 s on one thread: at least 0.2 s of CPU even on a loaded machine's tick count.
        // No upper bound: the process's CPU time includes the tests the harness runs beside this
        // one on other threads (a run with a chi-square test alongside measured 0.51 s).
        assert!(cpu > 0.2, "cpu {cpu} s for {wall} s of busy wall time");
    }

    #[test]
    fn peak_memory_covers_a_touched_allocation() {
        let v = vec![1u8; 64 << 20];
        assert!(
            peak_rss_bytes() >= 64 << 20,
            "{}",
            v.iter().map(|&b| b as u64).sum::<u64>()
        );
    }

    /// Where /proc/cpuinfo names the model, it is read without its key and padding.
    #[test]
    fn cpu_model_is_the_cpuinfo_model_name() {
        let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        match info.lines().find(|l| l.starts_with("model name")) {
            Some(line) => {
                let model = cpu_model().expect("a model name line");
                assert!(!model.is_empty() && !model.starts_with(':'), "{model:?}");
                assert!(line.ends_with(&model), "{line:?} against {model:?}");
            }
            None => assert_eq!(cpu_model(), None),
        }
    }
}
