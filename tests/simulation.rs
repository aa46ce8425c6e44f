//! A scene stepped by its caller (`sph_std::simulation`): pieces give the
//! run made in one call bit for bit, a written state evolves as the physics
//! says, and bad writes are refused with nothing changed.

use sph_std::cases::Settings;
use sph_std::couette::Silent;
use sph_std::error::Error;
use sph_std::scene::{self, Frame};
use sph_std::simulation::{Field, Simulation};

fn settings(text: &str) -> Settings {
    let mut s = Settings::from_toml(text).unwrap();
    s.threads = 1;
    s
}

fn bits(frame: &Frame) -> Vec<u64> {
    let mut out = Vec::new();
    for i in 0..frame.x.len() {
        out.extend(frame.x[i].iter().chain(&frame.v[i]).map(|v| v.to_bits()));
        out.push(frame.rho[i].to_bits());
        out.push(frame.p[i].to_bits());
    }
    out
}

#[test]
fn stepping_in_pieces_is_the_run_made_in_one_call() {
    // Pieces of 7 steps do not line up with the output times.
    for threads in [1, 2] {
        let mut s =
            settings("case = \"couette\"\nresolution = 10\nt_end = 0.05\noutput_interval = 0.01");
        s.threads = threads;
        let whole = scene::run(&sph_std::cases::scene(&s).unwrap(), &Silent).unwrap();
        let mut sim = Simulation::from_settings(&s).unwrap();
        assert_eq!(sim.steps(), 0);
        assert_eq!(sim.time(), 0.0);
        let mut calls = 0;
        while !sim.ended() {
            let taken = sim.advance(7).unwrap();
            assert!(taken <= 7);
            calls += 1;
        }
        assert!(calls > 2, "the run took {calls} calls");
        assert_eq!(sim.steps(), whole.steps);
        assert_eq!(sim.advance(10).unwrap(), 0, "an ended run takes no step");
        assert_eq!(sim.diagnostics(), &whole.outputs[..]);
        let last = whole.frames.last().unwrap();
        assert_eq!(bits(sim.state()), bits(last));
        // The field readers give the same state.
        let mut v = vec![0.0; sim.len(Field::Velocity)];
        sim.read(Field::Velocity, &mut v).unwrap();
        for (i, pair) in v.chunks(2).enumerate() {
            assert_eq!(pair, &last.v[i][..2]);
        }
        // At t = 0.05 the Couette error is the documented transient one.
        let linf = sim.diagnostics().last().unwrap().linf.unwrap();
        assert!(linf < 0.02, "Couette error {linf}");
    }
}

#[test]
fn a_uniform_velocity_written_into_a_periodic_box_is_carried_unchanged() {
    // Galilean invariance: a uniform flow in a fully periodic box is an
    // exact steady solution (no pressure or velocity differences), whatever
    // the vortex the case started with; every particle moves by U t.
    let s = settings(
        "case = \"taylor-green\"\nresolution = 16\nt_end = 0.02\noutput_interval = 0.01\n\
         density = \"summation\"\nviscosity = \"morris\"\nregularise = \"none\"",
    );
    let mut sim = Simulation::from_settings(&s).unwrap();
    let n = sim.particles();
    let u = [0.3, -0.1];
    let mut x0 = vec![0.0; 2 * n];
    sim.read(Field::Position, &mut x0).unwrap();
    let uniform: Vec<f64> = (0..n).flat_map(|_| u).collect();
    sim.write(Field::Velocity, &uniform).unwrap();
    let mut v = vec![0.0; 2 * n];
    sim.read(Field::Velocity, &mut v).unwrap();
    assert_eq!(v, uniform, "a write reads back");
    sim.run_to_end().unwrap();
    let t = sim.time();
    assert!((t - 0.02).abs() < 1e-12);
    sim.read(Field::Velocity, &mut v).unwrap();
    let mut x = vec![0.0; 2 * n];
    sim.read(Field::Position, &mut x).unwrap();
    let mut rho = vec![0.0; n];
    sim.read(Field::Density, &mut rho).unwrap();
    for i in 0..n {
        for a in 0..2 {
            let dv = (v[2 * i + a] - u[a]).abs();
            assert!(dv < 1e-10, "particle {i}: velocity off by {dv}");
            // Displacement modulo the unit box.
            let moved = x[2 * i + a] - x0[2 * i + a] - u[a] * t;
            let off = (moved - moved.round()).abs();
            assert!(off < 1e-10, "particle {i}: position off by {off}");
        }
        assert!(
            (rho[i] - 1.0).abs() < 1e-10,
            "particle {i}: density {}",
            rho[i]
        );
    }
}

#[test]
fn bad_writes_are_refused_with_nothing_changed() {
    let s = settings("case = \"couette\"\nresolution = 10\nt_end = 0.01");
    let mut sim = Simulation::from_settings(&s).unwrap();
    let n = sim.particles();
    let before = bits(sim.state());
    let key = |e: Error| match e {
        Error::Config { key, .. } => key,
        other => panic!("not a config error: {other}"),
    };
    assert_eq!(
        key(sim
            .write(Field::Velocity, &vec![0.0; 2 * n + 1])
            .unwrap_err()),
        "buffer"
    );
    let mut nan = vec![0.0; 2 * n];
    nan[7] = f64::NAN;
    let e = sim.write(Field::Velocity, &nan).unwrap_err();
    assert!(e.to_string().contains("particle 3"), "{e}");
    assert_eq!(
        key(sim.write(Field::Pressure, &vec![0.0; n]).unwrap_err()),
        "pressure"
    );
    // The case's default density mode is continuity: a zero density is refused.
    assert_eq!(
        key(sim.write(Field::Density, &vec![0.0; n]).unwrap_err()),
        "density"
    );
    let mut x = vec![0.0; 2 * n];
    sim.read(Field::Position, &mut x).unwrap();
    x[1] = -1.0; // below the lower plate
    let e = sim.write(Field::Position, &x).unwrap_err();
    assert!(e.to_string().contains("axis 1"), "{e}");
    assert_eq!(bits(sim.state()), before);
    let mut short = vec![0.0; 3];
    assert_eq!(
        key(sim.read(Field::Density, &mut short).unwrap_err()),
        "buffer"
    );
    // The run continues as if nothing had been asked.
    let whole = scene::run(&sph_std::cases::scene(&s).unwrap(), &Silent).unwrap();
    sim.run_to_end().unwrap();
    assert_eq!(bits(sim.state()), bits(whole.frames.last().unwrap()));
}
