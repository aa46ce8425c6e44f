//! A progress bar on stderr (indicatif), hidden when stderr is not a terminal
//! or when asked to be quiet, and the stop flag that SIGINT and SIGTERM set.
//! The bar needs the `progress-bar` feature (on by default; off for the
//! browser module, where indicatif's clock goes through JavaScript glue).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

#[cfg(feature = "progress-bar")]
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

#[cfg(feature = "progress-bar")]
use crate::couette::Progress;

/// The flag every progress bar reports through
/// [`crate::couette::Progress::cancelled`]; the
/// command line's SIGINT and SIGTERM handlers set it.
pub fn stop_flag() -> Arc<AtomicBool> {
    static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    STOP.get_or_init(|| Arc::new(AtomicBool::new(false)))
        .clone()
}

/// Asks running scenes to stop at the next step.
pub fn request_stop() {
    stop_flag().store(true, Ordering::SeqCst);
}

/// An indicatif bar implementing [`Progress`].
#[cfg(feature = "progress-bar")]
#[derive(Debug)]
pub struct Bar {
    bar: ProgressBar,
}

#[cfg(feature = "progress-bar")]
impl Bar {
    /// A bar labelled `label`; drawn nowhere when `quiet`.
    pub fn new(label: &str, quiet: bool) -> Self {
        let bar = ProgressBar::with_draw_target(
            Some(0),
            if quiet {
                ProgressDrawTarget::hidden()
            } else {
                ProgressDrawTarget::stderr()
            },
        );
        if let Ok(style) = ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} steps, eta {eta}",
        ) {
            bar.set_style(style);
        }
        bar.set_prefix(label.to_string());
        Self { bar }
    }
}

#[cfg(feature = "progress-bar")]
impl Progress for Bar {
    fn start(&self, total: u64) {
        self.bar.set_length(total);
        self.bar.set_position(0);
    }
    fn advance(&self, steps: u64) {
        self.bar.inc(steps);
    }
    fn finish(&self) {
        self.bar.finish_and_clear();
    }
    fn cancelled(&self) -> bool {
        stop_flag().load(Ordering::Relaxed)
    }
}
