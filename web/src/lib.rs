//! sph in a browser: a built-in case, given as a scene file's text, run by
//! sph-std's [`Simulation`] in a wasm32 module with plain exported functions
//! (no wasm-bindgen), driven by `web/index.html`.
//!
//! The module is the scene layer that `sph run` uses, single-threaded
//! (`threads = 1`: the executor is the core's serial one, no rayon pool is
//! started), with no file or clock access on the run's path. So the page's
//! figures can be checked against `sph run` on the same scene file:
//! `cargo xtask web` runs the page headless, reads the scene text and the
//! error it reports from the DOM, runs `sph run` on that text natively, and
//! compares the two.
//!
//! The page hands the scene text in through [`exports::sph_input`] (a
//! buffer in the module's memory), starts it with [`exports::sph_start`],
//! and advances it frame by frame; errors come back as the same one-line
//! messages as the CLI's, through [`exports::sph_text`].

use std::cell::RefCell;

pub use sph_std::cases::Settings;
pub use sph_std::simulation::{Field, Simulation};

/// Starts the run of a scene file's text (a built-in case and its keys).
///
/// # Errors
/// The message of the scene's error, as `sph run` prints it.
pub fn start(toml: &str) -> Result<Simulation, String> {
    let settings = Settings::from_toml(toml).map_err(|e| e.to_string())?;
    Simulation::from_settings(&settings).map_err(|e| e.to_string())
}

/// A built-in case's default settings as scene-file text (every key, as
/// `sph run` writes them into config.toml).
///
/// # Errors
/// The message for an unknown case.
pub fn defaults(case: &str) -> Result<String, String> {
    let mut table = toml::Table::new();
    table.insert("case".into(), toml::Value::String(case.into()));
    Settings::from_toml(&table.to_string())
        .and_then(|s| s.to_toml())
        .map_err(|e| e.to_string())
}

/// The latest output time reached and its velocity error against the exact
/// solution (`max |v - v_exact|` over the error scale), if the case has
/// one and an output time was reached.
pub fn latest_error(sim: &Simulation) -> Option<(f64, f64)> {
    let d = sim.diagnostics().last()?;
    Some((d.t, d.linf?))
}

/// Writes `x, y, u, v` per particle (global coordinates; the first two
/// components in 3D) into `out`, cleared first: from the paused state, as
/// [`Simulation::read`] copies it.
pub fn view_into(sim: &Simulation, out: &mut Vec<f64>) {
    let state = sim.state();
    out.clear();
    out.reserve(4 * state.x.len());
    for (x, v) in state.x.iter().zip(&state.v) {
        out.extend_from_slice(&[x[0], x[1], v[0], v[1]]);
    }
}

/// The functions the page calls by name. `no_mangle` is all the `unsafe`
/// lint sees here: there is no unsafe block in this crate.
#[allow(unsafe_code)]
pub mod exports {
    use super::*;

    thread_local! {
        /// The page's run (a wasm module has one thread).
        static RUN: RefCell<Option<Simulation>> = const { RefCell::new(None) };
        /// The scene text the page writes before [`sph_start`].
        static INPUT: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
        /// The text the last call left for the page (UTF-8): an error's
        /// message, or a case's defaults.
        static TEXT: RefCell<String> = const { RefCell::new(String::new()) };
        /// `x, y, u, v` per particle, for the page to read through a pointer.
        static VIEW: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    }

    fn failed(message: String) -> i32 {
        TEXT.with(|m| *m.borrow_mut() = message);
        1
    }

    fn input() -> Result<String, String> {
        INPUT
            .with(|b| String::from_utf8(b.borrow().clone()))
            .map_err(|_| "the text is not UTF-8".to_owned())
    }

    /// A buffer of `len` bytes for the page's text (a scene file, or a
    /// case's name); the page writes the text there, then calls
    /// [`sph_start`] or [`sph_defaults`].
    #[no_mangle]
    pub extern "C" fn sph_input(len: u32) -> *mut u8 {
        INPUT.with(|b| {
            let mut b = b.borrow_mut();
            b.clear();
            b.resize(len as usize, 0);
            b.as_mut_ptr()
        })
    }

    /// The defaults of the case named in [`sph_input`]'s buffer, as
    /// scene-file text in [`sph_text`]; 0 on success, 1 with the reason
    /// there.
    #[no_mangle]
    pub extern "C" fn sph_defaults() -> i32 {
        match input().and_then(|case| defaults(&case)) {
            Ok(text) => {
                TEXT.with(|t| *t.borrow_mut() = text);
                0
            }
            Err(e) => failed(e),
        }
    }

    /// Starts the scene written into [`sph_input`]'s buffer; 0 on success,
    /// 1 with the reason in [`sph_text`] (the previous run is dropped
    /// either way).
    #[no_mangle]
    pub extern "C" fn sph_start() -> i32 {
        RUN.with(|r| *r.borrow_mut() = None);
        match input().and_then(|text| start(&text)) {
            Ok(sim) => {
                RUN.with(|r| *r.borrow_mut() = Some(sim));
                0
            }
            Err(e) => failed(e),
        }
    }

    /// Takes up to `steps` steps (fewer at the end time); 0 on success, 1
    /// with the reason in [`sph_text`] (no run, or it diverged).
    #[no_mangle]
    pub extern "C" fn sph_advance(steps: u32) -> i32 {
        let outcome = RUN.with(|r| match r.borrow_mut().as_mut() {
            None => Err("no run: call sph_start first".to_owned()),
            Some(sim) => sim
                .advance(u64::from(steps))
                .map(|_| ())
                .map_err(|e| e.to_string()),
        });
        match outcome {
            Ok(()) => 0,
            Err(e) => failed(e),
        }
    }

    /// Where the text of the last call that left one (an error's message,
    /// a case's defaults) starts in the module's memory ([`sph_text_len`]
    /// bytes of UTF-8).
    #[no_mangle]
    pub extern "C" fn sph_text() -> *const u8 {
        TEXT.with(|m| m.borrow().as_ptr())
    }

    /// That text's length in bytes.
    #[no_mangle]
    pub extern "C" fn sph_text_len() -> u32 {
        TEXT.with(|m| m.borrow().len() as u32)
    }

    fn with_run(f: impl FnOnce(&Simulation) -> f64) -> f64 {
        RUN.with(|r| r.borrow().as_ref().map_or(f64::NAN, f))
    }

    /// Simulated time in s (NaN without a run).
    #[no_mangle]
    pub extern "C" fn sph_time() -> f64 {
        with_run(Simulation::time)
    }

    /// The run's end time in s.
    #[no_mangle]
    pub extern "C" fn sph_end_time() -> f64 {
        with_run(Simulation::end_time)
    }

    /// 1 once the run reached its end time (or a steady state), else 0.
    #[no_mangle]
    pub extern "C" fn sph_ended() -> f64 {
        with_run(|s| f64::from(u8::from(s.ended())))
    }

    /// Steps taken.
    #[no_mangle]
    pub extern "C" fn sph_steps() -> f64 {
        with_run(|s| s.steps() as f64)
    }

    /// Fluid particles.
    #[no_mangle]
    pub extern "C" fn sph_particles() -> f64 {
        with_run(|s| s.particles() as f64)
    }

    /// The initial particle spacing in m.
    #[no_mangle]
    pub extern "C" fn sph_dx() -> f64 {
        with_run(|s| s.scene().dx)
    }

    /// The box: `k` = 0, 1 its origin's x and y, 2, 3 its extent's (m).
    #[no_mangle]
    pub extern "C" fn sph_box(k: u32) -> f64 {
        with_run(|s| {
            let scene = s.scene();
            match k {
                0 | 1 => scene.origin[k as usize],
                2 | 3 => scene.extent[k as usize - 2],
                _ => f64::NAN,
            }
        })
    }

    /// The latest output time with an error against the exact solution
    /// (NaN before the first, or for a case without one).
    #[no_mangle]
    pub extern "C" fn sph_error_time() -> f64 {
        with_run(|s| latest_error(s).map_or(f64::NAN, |(t, _)| t))
    }

    /// The error at [`sph_error_time`]: `max |v - v_exact|` over the case's
    /// error scale, as summary.json's `linf` (NaN where there is none).
    #[no_mangle]
    pub extern "C" fn sph_error() -> f64 {
        with_run(|s| latest_error(s).map_or(f64::NAN, |(_, e)| e))
    }

    /// Fills the view with `x, y, u, v` per particle and returns the
    /// particle count (0 without a run); [`sph_view`] points at it until
    /// the next call.
    #[no_mangle]
    pub extern "C" fn sph_fill_view() -> u32 {
        RUN.with(|r| match r.borrow().as_ref() {
            None => 0,
            Some(sim) => VIEW.with(|v| {
                view_into(sim, &mut v.borrow_mut());
                sim.particles() as u32
            }),
        })
    }

    /// Where the view's values start in the module's memory.
    #[no_mangle]
    pub extern "C" fn sph_view() -> *const f64 {
        VIEW.with(|v| v.borrow().as_ptr())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_scene_comes_back_as_the_cli_message() {
        let e = start("case = \"taylor-green\"\nresolution = 0")
            .err()
            .expect("resolution 0 is refused");
        assert!(e.contains("resolution"), "{e}");
        let e = start("case = \"no-such-case\"")
            .err()
            .expect("an unknown case is refused");
        assert!(e.contains("no-such-case"), "{e}");
    }

    #[test]
    fn defaults_are_a_scene_file_that_starts() {
        let text = defaults("couette").expect("couette is built in");
        assert!(text.contains("case = \"couette\""), "{text}");
        let settings = Settings::from_toml(&text).expect("the defaults read back");
        assert_eq!(settings.case, "couette");
        assert!(defaults("no-such-case").is_err());
    }

    #[test]
    fn the_view_holds_the_particles_in_order() {
        let mut sim = start("case = \"taylor-green\"\nresolution = 8\nt_end = 0.01\nthreads = 1")
            .expect("the scene starts");
        sim.run_to_end().expect("the run ends");
        let mut view = Vec::new();
        view_into(&sim, &mut view);
        assert_eq!(view.len(), 4 * 64);
        let mut v = vec![0.0; sim.len(Field::Velocity)];
        sim.read(Field::Velocity, &mut v).unwrap();
        assert_eq!(view[2], v[0]);
        assert_eq!(view[4 * 63 + 3], v[2 * 63 + 1]);
        let (t, e) = latest_error(&sim).expect("taylor-green has an exact solution");
        assert_eq!(t, sim.time());
        // The exact solution decays by exp(-8 pi^2 nu t); 8 across is coarse,
        // but the error stays a fraction of the amplitude.
        assert!(e > 0.0 && e < 0.5, "{e}");
    }
}
