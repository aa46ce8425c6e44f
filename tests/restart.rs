//! Checkpoint and restart: a run continued from a checkpoint (periodic or
//! taken at a stop request) is bitwise the run that was never stopped, on
//! one thread and on several, and after a round trip through the file
//! format.

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use sph_std::cases::{self, Settings};
use sph_std::checkpoint::Checkpoint;
use sph_std::couette::{Progress, Silent};
use sph_std::scene::{self, Frame, RunControl, RunRecord};

fn settings(case: &str, resolution: usize, t_end: f64, threads: usize) -> Settings {
    let mut s = (cases::find(case).unwrap().defaults)();
    s.resolution = resolution;
    s.t_end = t_end;
    s.output_interval = t_end / 4.0;
    s.threads = threads;
    s
}

/// Runs `s`, from `resume` if given, collecting the periodic checkpoints.
fn run(
    s: &Settings,
    progress: &dyn Progress,
    resume: Option<&Checkpoint>,
    every: Option<f64>,
) -> (RunRecord, Vec<Checkpoint>) {
    let scene = cases::scene(s).unwrap();
    let mut taken = Vec::new();
    let mut keep = |_: &RunRecord, ck: &Checkpoint| {
        taken.push(ck.clone());
        Ok(())
    };
    let record = scene::run_with(
        &scene,
        &mut RunControl {
            progress,
            resume,
            checkpoint_every: every,
            on_checkpoint: &mut keep,
            pause_after: None,
            refresh: false,
            ranks: None,
        },
    )
    .unwrap();
    (record, taken)
}

fn frame_bits(frames: &[Frame]) -> Vec<u64> {
    let mut out = Vec::new();
    for f in frames {
        out.push(f.t.to_bits());
        for k in 0..f.x.len() {
            out.extend(f.x[k].iter().chain(&f.v[k]).map(|c| c.to_bits()));
            out.push(f.rho[k].to_bits());
            out.push(f.p[k].to_bits());
        }
    }
    out
}

fn assert_same_run(a: &RunRecord, b: &RunRecord, what: &str) {
    assert!(
        a.complete() && b.complete(),
        "{what}: {:?} {:?}",
        a.stop,
        b.stop
    );
    assert_eq!(a.steps, b.steps, "{what}: steps");
    assert_eq!(a.outputs, b.outputs, "{what}: diagnostics");
    assert_eq!(
        frame_bits(&a.frames),
        frame_bits(&b.frames),
        "{what}: particles"
    );
}

/// Round trip through the file format.
fn through_file(ck: &Checkpoint) -> Checkpoint {
    Checkpoint::from_bytes(&ck.to_bytes(), Path::new("memory")).unwrap()
}

#[test]
fn resuming_a_periodic_checkpoint_reproduces_the_run_bit_for_bit() {
    // Walls and a body force (Poiseuille), the periodic box with shifting
    // (Taylor-Green), a moving lid with the consistent operators (cavity), a
    // free surface with the energy budget (hydrostatic).
    for (case, resolution, t_end) in [
        ("poiseuille", 12, 0.05),
        ("taylor-green", 16, 0.1),
        ("lid-driven-cavity", 12, 0.3),
        // The energy budget's running sums, under a gravity ramp.
        ("hydrostatic", 10, 0.3),
    ] {
        for threads in [1, 2] {
            let s = settings(case, resolution, t_end, threads);
            let (whole, taken) = run(&s, &Silent, None, Some(t_end / 3.0));
            // Checkpoints land between output times as well as on them.
            assert!(taken.len() >= 2, "{case}: {} checkpoints", taken.len());
            for ck in &taken {
                let steps = StopAfter::never();
                let (resumed, _) = run(&s, &steps, Some(&through_file(ck)), None);
                // It stepped from the checkpoint, not from the start.
                assert_eq!(
                    steps.polls.load(Ordering::Relaxed),
                    whole.steps - ck.state.steps,
                    "{case}"
                );
                assert_same_run(
                    &whole,
                    &resumed,
                    &format!("{case}, {threads} thread(s), from t = {}", ck.state.time),
                );
            }
            // Checkpointing itself changes nothing.
            let (plain, _) = run(&s, &Silent, None, None);
            assert_same_run(&whole, &plain, case);
        }
    }
}

#[test]
fn an_adaptive_step_is_the_same_on_any_thread_count_and_after_a_resume() {
    // The step follows the state (largest speed and acceleration, maxima
    // that do not depend on the order of a reduction), so the step sequence,
    // and with it every particle, is the same on one thread and on two, and
    // a resumed run picks it up where it stopped; under a gravity ramp, with
    // the energy budget running.
    let t_end = 0.6;
    let mut runs = Vec::new();
    for threads in [1, 2] {
        let mut s = settings("hydrostatic", 10, t_end, threads);
        s.adaptive_dt = true;
        let (whole, taken) = run(&s, &Silent, None, Some(t_end / 3.0));
        let [lo, hi] = whole.dt_range.expect("an adaptive run reports its steps");
        assert!(0.0 < lo && lo <= hi, "{lo} {hi}");
        assert!(taken.len() >= 2, "{} checkpoints", taken.len());
        for ck in &taken {
            let (resumed, _) = run(&s, &Silent, Some(&through_file(ck)), None);
            let what = format!("adaptive, {threads} thread(s), from t = {}", ck.state.time);
            assert_same_run(&whole, &resumed, &what);
            assert_eq!(whole.dt_range, resumed.dt_range, "{what}");
        }
        runs.push(whole);
    }
    assert_same_run(&runs[0], &runs[1], "adaptive, 1 against 2 threads");
    assert_eq!(runs[0].dt_range, runs[1].dt_range);
}

/// Asks the run to stop after `after` polls.
struct StopAfter {
    polls: AtomicU64,
    after: u64,
}

impl StopAfter {
    fn never() -> Self {
        Self {
            polls: AtomicU64::new(0),
            after: u64::MAX,
        }
    }
}

impl Progress for StopAfter {
    fn start(&self, _total: u64) {}
    fn advance(&self, _steps: u64) {}
    fn finish(&self) {}
    fn cancelled(&self) -> bool {
        self.polls.fetch_add(1, Ordering::Relaxed) >= self.after
    }
}

#[test]
fn a_run_stopped_mid_interval_resumes_on_another_thread_count_bit_for_bit() {
    let serial = settings("taylor-green", 16, 0.1, 1);
    let (whole, _) = run(&serial, &Silent, None, None);
    let stop = StopAfter {
        polls: AtomicU64::new(0),
        after: whole.steps / 2 + 7,
    };
    let (stopped, _) = run(&serial, &stop, None, None);
    assert!(!stopped.complete());
    let ck = stopped
        .checkpoint
        .expect("a stopped run carries its checkpoint");
    assert_eq!(ck.state.steps, whole.steps / 2 + 7);
    assert!(stopped.outputs.len() < whole.outputs.len());
    // Stopped on one thread, resumed on two: the split never changes bits.
    let parallel = Settings {
        threads: 2,
        ..serial.clone()
    };
    let (resumed, _) = run(&parallel, &Silent, Some(&through_file(&ck)), None);
    assert_same_run(&whole, &resumed, "stopped at half time");
}

#[test]
fn the_comparison_sees_a_one_bit_change_in_the_checkpoint() {
    // The bitwise assertions above are not vacuous: the last bit of one
    // velocity component, changed in the checkpoint, reaches the outputs.
    let s = settings("poiseuille", 12, 0.05, 1);
    let (whole, taken) = run(&s, &Silent, None, Some(0.02));
    let mut ck = taken[0].clone();
    let v = &mut ck.arrays.reals[1];
    v[0] = f64::from_bits(v[0].to_bits() ^ 1);
    let (perturbed, _) = run(&s, &Silent, Some(&ck), None);
    assert!(perturbed.complete());
    assert_ne!(frame_bits(&whole.frames), frame_bits(&perturbed.frames));
}

#[test]
fn a_checkpoint_of_another_scene_is_refused_with_a_clear_error() {
    let s = settings("poiseuille", 12, 0.02, 1);
    let (_, taken) = run(&s, &Silent, None, Some(0.01));
    let other = settings("poiseuille", 14, 0.02, 1);
    let scene = cases::scene(&other).unwrap();
    let mut none = |_: &RunRecord, _: &Checkpoint| Ok(());
    let err = scene::run_with(
        &scene,
        &mut RunControl {
            progress: &Silent,
            resume: Some(&taken[0]),
            checkpoint_every: None,
            on_checkpoint: &mut none,
            pause_after: None,
            refresh: false,
            ranks: None,
        },
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("checkpoint"), "{err}");
}
