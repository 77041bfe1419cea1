//! A progress bar on a terminal; silent when stderr is not one.

use indicatif::{ProgressBar, ProgressStyle};
use toolpath_planners::Progress;

pub struct Bar(ProgressBar);

impl Bar {
    pub fn new(message: &str) -> Self {
        // ProgressBar draws to stderr and hides itself when it is not a terminal.
        let bar = ProgressBar::new(1000);
        bar.set_style(
            ProgressStyle::with_template("{msg} [{bar:40}] {percent:>3}% {elapsed}")
                .expect("static template")
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        Self(bar)
    }
    pub fn finish(&self) {
        self.0.finish_and_clear();
    }
}

impl Progress for Bar {
    fn set(&self, fraction: f32) {
        self.0
            .set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
    }
}
