//! The bare-metal C ABI, called as C calls it: with the firmware's
//! parameters it gives the firmware's velocities bit for bit (the same
//! hash of every velocity's bits at every output time), its error against
//! the exact series falls as the run approaches the steady profile, and bad
//! input comes back as status codes with the storage left uninitialised.

#![allow(unsafe_code)]

#[path = "../../../examples/firmware/src/scene.rs"]
#[allow(dead_code)]
mod scene;

use sph_bare::*;
use sph_core::math::Libm;

fn firmware_params() -> SphBareCouette {
    let u = 1.25e-5f32;
    SphBareCouette {
        particles_across: 16,
        gap: 1e-3,
        wall_speed: u,
        nu: 1e-6,
        rho0: 1000.0,
        sound_speed: 10.0 * u,
        beta: 1.3,
        dt_factor: 0.7,
    }
}

fn storage() -> Box<SphBare> {
    Box::new(SphBare {
        words: [0; SPH_BARE_WORDS],
    })
}

fn fnv(hash: &mut u32, word: u32) {
    for byte in word.to_le_bytes() {
        *hash ^= u32::from(byte);
        *hash = hash.wrapping_mul(0x0100_0193);
    }
}

#[test]
fn the_firmware_parameters_give_the_firmware_bits() {
    let mut store = scene::SceneStore::new();
    let mut lines = Vec::new();
    scene::run::<Libm>(&mut store, true, |line| lines.push(line)).unwrap();
    let mut bare = storage();
    let p = firmware_params();
    // SAFETY: valid storage and parameters; buffers of the asked length.
    unsafe {
        assert_eq!(sph_bare_init(&mut *bare, &p), SphBareStatus::Ok);
        let n = sph_bare_particles(&*bare) as usize;
        assert_eq!(n, 16 * 6);
        let mut v = vec![0.0f32; 2 * n];
        for line in &lines {
            let t = f64::from(line.t_ms) * 1e-3;
            assert_eq!(sph_bare_advance_to(&mut *bare, t), SphBareStatus::Ok);
            assert_eq!(sph_bare_steps(&*bare), u64::from(line.steps));
            assert_eq!(
                sph_bare_velocities(&mut *bare, v.as_mut_ptr(), v.len() as u32),
                SphBareStatus::Ok
            );
            let mut hash = 0x811c_9dc5u32;
            for x in &v {
                fnv(&mut hash, x.to_bits());
            }
            assert_eq!(hash, line.hash, "t = {} ms", line.t_ms);
            let linf = sph_bare_linf(&mut *bare);
            // The firmware rounds to parts per million.
            assert!(
                (linf * 1e6 - f64::from(line.linf_ppm)).abs() <= 0.5 + 1e-6,
                "t = {} ms: {linf:e} against {} ppm",
                line.t_ms,
                line.linf_ppm
            );
        }
        // Towards the steady linear profile the error falls (docs: 0.38 %,
        // 0.20 %, 0.11 % at t* = 0.05, 0.1, 0.2).
        let ppm: Vec<u32> = lines.iter().map(|l| l.linf_ppm).collect();
        assert!(ppm.windows(2).skip(1).all(|w| w[1] < w[0]), "{ppm:?}");
    }
}

#[test]
fn bad_input_is_a_status_and_leaves_the_storage_uninitialised() {
    let mut bare = storage();
    let mut p = firmware_params();
    // SAFETY: valid storage and parameters, null where the test says.
    unsafe {
        assert_eq!(sph_bare_step(&mut *bare, 1), SphBareStatus::NotInitialised);
        assert!(sph_bare_time(&*bare).is_nan());
        assert_eq!(
            sph_bare_init(std::ptr::null_mut(), &p),
            SphBareStatus::NullPointer
        );
        assert_eq!(
            sph_bare_init(&mut *bare, std::ptr::null()),
            SphBareStatus::NullPointer
        );
        p.particles_across = SPH_BARE_MAX_ACROSS + 1;
        assert_eq!(
            sph_bare_init(&mut *bare, &p),
            SphBareStatus::InvalidParameter
        );
        p = firmware_params();
        p.nu = f32::NAN;
        assert_eq!(
            sph_bare_init(&mut *bare, &p),
            SphBareStatus::InvalidParameter
        );
        assert_eq!(sph_bare_step(&mut *bare, 1), SphBareStatus::NotInitialised);
        // The largest resolution fits its storage.
        p = firmware_params();
        p.particles_across = SPH_BARE_MAX_ACROSS;
        assert_eq!(sph_bare_init(&mut *bare, &p), SphBareStatus::Ok);
        assert_eq!(sph_bare_step(&mut *bare, 10), SphBareStatus::Ok);
        let mut short = [0.0f32; 3];
        assert_eq!(
            sph_bare_velocities(&mut *bare, short.as_mut_ptr(), 3),
            SphBareStatus::BufferLength
        );
        assert_eq!(
            sph_bare_advance_to(&mut *bare, -1.0),
            SphBareStatus::InvalidParameter
        );
        assert!(sph_bare_time(&*bare) > 0.0);
    }
}
