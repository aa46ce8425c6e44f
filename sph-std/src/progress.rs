//! A progress bar on stderr (indicatif), hidden when stderr is not a terminal
//! or when asked to be quiet.

use std::sync::atomic::{AtomicBool, Ordering};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::couette::Progress;

/// Set by the command line's SIGINT handler ([`request_stop`]); every
/// [`Bar`] reports it through [`Progress::cancelled`].
static STOP: AtomicBool = AtomicBool::new(false);

/// Asks running scenes to stop at the next step (safe from a signal handler).
pub fn request_stop() {
    STOP.store(true, Ordering::SeqCst);
}

/// An indicatif bar implementing [`Progress`].
#[derive(Debug)]
pub struct Bar {
    bar: ProgressBar,
}

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
        STOP.load(Ordering::Relaxed)
    }
}
