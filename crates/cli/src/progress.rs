//! Progress bars on the terminal (indicatif), behind the integrators' `Progress` trait.

use indicatif::{ProgressBar, ProgressStyle};
use lightlab_core::Progress;

pub struct Bar(pub ProgressBar);

impl Bar {
    pub fn new(message: &str) -> Bar {
        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template(
                "{msg} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        Bar(bar)
    }
}

impl Progress for Bar {
    fn start(&self, total: u64) {
        self.0.set_length(total);
        self.0.set_position(0);
    }
    fn advance(&self, n: u64) {
        self.0.inc(n);
    }
}
