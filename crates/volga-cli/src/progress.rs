//! A progress bar on stderr for kernel steps that run longer than a second; silent
//! when stderr is not a terminal (indicatif hides its bar there).

use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use volga_core::Progress;

pub struct BarProgress {
    state: Mutex<Option<(ProgressBar, Instant, bool)>>,
}

const SHOW_AFTER: Duration = Duration::from_secs(1);

impl BarProgress {
    pub fn new() -> Self {
        BarProgress {
            state: Mutex::new(None),
        }
    }
}

impl Progress for BarProgress {
    fn start(&self, stage: &str, total: u64) {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} ({eta})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_message(stage.to_string());
        *self.state.lock().expect("progress lock") = Some((bar, Instant::now(), false));
    }

    fn inc(&self, n: u64) {
        let mut guard = self.state.lock().expect("progress lock");
        if let Some((bar, started, shown)) = guard.as_mut() {
            if !*shown && started.elapsed() >= SHOW_AFTER {
                bar.set_draw_target(ProgressDrawTarget::stderr());
                *shown = true;
            }
            bar.inc(n);
        }
    }

    fn finish(&self) {
        if let Some((bar, _, _)) = self.state.lock().expect("progress lock").take() {
            bar.finish_and_clear();
        }
    }
}
