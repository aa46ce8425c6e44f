//! The `sph` command line as a user meets it: outputs, repeatability, bad input.

use std::path::{Path, PathBuf};
use std::process::Command;

fn sph() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sph"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sph-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn quick_run(out: &Path, extra: &[&str]) -> std::process::Output {
    sph()
        .args([
            "couette",
            "--quiet",
            "--particles-across",
            "16",
            "--t-end",
            "0.05",
            "--output-times",
            "0.0225,0.05",
        ])
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn a_run_writes_every_output_and_its_config_repeats_it_exactly() {
    let out = scratch("run");
    let result = quick_run(&out, &["--vtk"]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    for name in [
        "summary.json",
        "profile.csv",
        "profiles.png",
        "config.toml",
        "particles.pvd",
        "particles_0000.vtu",
        "particles_0001.vtu",
    ] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    for key in [
        "\"y_lower\"",
        "\"y_upper\"",
        "\"U\"",
        "\"nu\"",
        "\"rho0\"",
        "\"particles_across\"",
        "\"beta\"",
        "\"kernel\"",
        "\"viscosity\"",
        "\"precision\"",
        "\"threads\"",
        "\"t_end\"",
        "\"steps\"",
        "\"wall_seconds\"",
        "\"linf_error\"",
        "\"l2_error\"",
        "\"errors\"",
    ] {
        assert!(summary.contains(key), "summary.json lacks {key}");
    }
    let csv = std::fs::read_to_string(out.join("profile.csv")).unwrap();
    assert!(csv.starts_with("t,y,vx,vx_exact\n"));
    assert_eq!(csv.lines().count(), 1 + 2 * 16 * csv_rows_per_height(&csv));
    assert_eq!(
        &std::fs::read(out.join("profiles.png")).unwrap()[1..4],
        b"PNG"
    );
    // The written config reproduces the run bit for bit.
    let again = scratch("again");
    let status = sph()
        .args(["couette", "--quiet", "--config"])
        .arg(out.join("config.toml"))
        .arg("--out")
        .arg(&again)
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(
        csv,
        std::fs::read_to_string(again.join("profile.csv")).unwrap()
    );
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&again);
}

/// Particles per row of the lattice (the strip width), read off the first time's rows.
fn csv_rows_per_height(csv: &str) -> usize {
    let first_t = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .to_string();
    let ys: Vec<&str> = csv
        .lines()
        .skip(1)
        .filter(|l| l.starts_with(&format!("{first_t},")))
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    ys.len() / 16
}

#[test]
fn bad_input_is_one_line_exit_two_and_leaves_nothing() {
    let cases: &[(&[&str], &[&str])] = &[
        (&["--nu", "-1e-6"], &["nu", "-0.000001", "positive"]),
        (&["--beta", "3.5"], &["beta", "3.5", "between 1.0 and 3.0"]),
        (
            &["--particles-across", "2"],
            &["particles_across", "2", "between 4 and 4000"],
        ),
        (
            &["--kernel", "spline"],
            &["spline", "--kernel", "wendland-c2"],
        ),
        (
            &["--config", "/nonexistent/sph.toml"],
            &["/nonexistent/sph.toml", "read config"],
        ),
        (
            &["--precision", "f64", "--math", "micromath"],
            &["math", "micromath", "f32"],
        ),
        (
            &["--strip-supports", "1"],
            &["strip_supports", "1", "two kernel supports"],
        ),
    ];
    for (args, words) in cases {
        let out = scratch("bad");
        let result = sph()
            .arg("couette")
            .args(*args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(
            stderr.trim_end().lines().count(),
            1,
            "{args:?}: not one line: {stderr}"
        );
        for w in *words {
            assert!(stderr.contains(w), "{args:?}: {stderr} lacks {w}");
        }
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
    // An output directory that cannot be created.
    let result = quick_run(Path::new("/proc/sph-cannot-exist"), &[]);
    assert_eq!(result.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&result.stderr).contains("/proc/sph-cannot-exist"));
}

#[test]
fn a_bad_config_file_names_the_line_key_and_value() {
    let dir = scratch("cfg");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("c.toml");
    std::fs::write(&file, "particles_across = 20\nkernel = \"spline\"\n").unwrap();
    let result = sph()
        .args(["couette", "--config"])
        .arg(&file)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2));
    assert!(
        stderr.contains("line 2")
            && stderr.contains("kernel = \"spline\"")
            && stderr.contains("cubic"),
        "{stderr}"
    );
    assert!(!dir.join("out").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_documented_example_config_is_the_default() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/couette.toml");
    let documented = sph_std::config::CouetteConfig::from_file(&path).unwrap();
    assert_eq!(documented, sph_std::config::CouetteConfig::default());
}

#[test]
fn sph_cases_lists_every_built_in_case() {
    let out = sph().arg("cases").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for name in ["couette", "poiseuille", "taylor-green", "lid-driven-cavity"] {
        assert!(text.contains(name), "{name} missing from:\n{text}");
    }
}

#[test]
fn a_collapsed_run_publishes_its_results_and_exits_with_status_one() {
    let out = scratch("collapse");
    let result = sph()
        .args([
            "run",
            "taylor-green",
            "--quiet",
            "--resolution",
            "32",
            "--t-end",
            "1",
            "--regularise",
            "none",
            "--threads",
            "1",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(result.status.code(), Some(1));
    let err = String::from_utf8_lossy(&result.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("particle") && err.contains("t = "), "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], false);
    assert!(summary["reason"]
        .as_str()
        .unwrap()
        .contains("closest neighbour"));
    let csv = std::fs::read_to_string(out.join("particles.csv")).unwrap();
    assert!(csv.starts_with("t,id,x,y,vx,vy,rho,p\n"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn an_unknown_case_or_key_is_one_clear_line_and_leaves_nothing() {
    let out = scratch("unknown");
    let result = sph()
        .args(["run", "vortex"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(result.status.code(), Some(2));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        err.contains("taylor-green") && err.trim().lines().count() == 1,
        "{err}"
    );
    assert!(!out.exists());
    let file = std::env::temp_dir().join(format!("sph-cli-{}-bad.toml", std::process::id()));
    std::fs::write(&file, "case = \"poiseuille\"\nresolutoin = 20\n").unwrap();
    let result = sph()
        .arg("run")
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(result.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&result.stderr).contains("resolutoin"));
    assert!(!out.exists());
    let _ = std::fs::remove_file(&file);
}

/// Sends `signal` (a name such as `INT`) to process `pid` with kill(1).
#[cfg(unix)]
fn send(signal: &str, pid: u32) {
    let status = Command::new("kill")
        .args([format!("-{signal}"), pid.to_string()])
        .status()
        .unwrap();
    assert!(status.success(), "kill -{signal} {pid}");
}

/// Sends `signal` to a long scene run after its first outputs and checks
/// that it stops with `status`, publishing what it computed.
#[cfg(unix)]
fn signal_stops_a_scene_run(signal: &str, status: i32) {
    let out = scratch(signal);
    let child = sph()
        .args([
            "run",
            "taylor-green",
            "--quiet",
            "--resolution",
            "128",
            "--threads",
            "1",
        ])
        .arg("--out")
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Let it pass its first output times (0.05 apart, ~100 steps each).
    std::thread::sleep(std::time::Duration::from_millis(2500));
    send(signal, child.id());
    let result = child.wait_with_output().unwrap();
    assert_eq!(result.status.code(), Some(status), "{signal}");
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("interrupted"), "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], false);
    for name in ["particles.csv", "config.toml", "diagnostics.png"] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[cfg(unix)]
#[test]
fn sigint_stops_a_scene_run_and_publishes_what_it_computed() {
    signal_stops_a_scene_run("INT", 130);
}

#[cfg(unix)]
#[test]
fn sigterm_stops_a_scene_run_with_status_143() {
    signal_stops_a_scene_run("TERM", 143);
}

#[test]
fn a_closed_or_full_stdout_ends_quietly_without_a_panic() {
    // `sph couette | true`: the reader is gone before the table is printed.
    let out = scratch("pipe");
    let mut child = sph()
        .args(["couette", "--particles-across", "16", "--t-end", "0.05"])
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let result = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(0), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let _ = std::fs::remove_dir_all(&out);
    // A full device: one line and status 1.
    if Path::new("/dev/full").exists() {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let result = sph().arg("cases").stdout(full).output().unwrap();
        let err = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(1), "{err}");
        assert!(err.contains("cannot write to standard output"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// Every file name in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn an_output_set_is_replaced_whole_or_not_at_all() {
    let out = scratch("sets");
    // A run with VTK snapshots, then one without: none of the first run's
    // snapshots survive beside the second run's summary.
    assert!(quick_run(&out, &["--vtk"]).status.success());
    assert!(listing(&out).iter().any(|n| n.ends_with(".vtu")));
    assert!(quick_run(&out, &[]).status.success());
    assert_eq!(
        listing(&out),
        [
            ".sph-output",
            "config.toml",
            "profile.csv",
            "profiles.png",
            "summary.json"
        ]
    );
    // Bad input leaves the previous set byte for byte.
    let before = std::fs::read(out.join("summary.json")).unwrap();
    let result = quick_run(&out, &["--nu=-1"]);
    assert_eq!(result.status.code(), Some(2));
    assert_eq!(std::fs::read(out.join("summary.json")).unwrap(), before);
    // A run that diverges replaces it with what it computed, marked
    // incomplete with the reason, and no checkpoint (nothing to continue).
    let result = quick_run(&out, &["--u-wall", "10", "--nu", "1e-9"]);
    assert_eq!(result.status.code(), Some(1));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        err.contains("diverged") && err.contains("complete: false"),
        "{err}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], false);
    assert!(summary["reason"].as_str().unwrap().contains("diverged"));
    assert_eq!(summary["U"], 10.0);
    assert_eq!(
        listing(&out),
        [
            ".sph-output",
            "config.toml",
            "profile.csv",
            "profiles.png",
            "summary.json"
        ]
    );
    // Nothing temporary is left beside it.
    let parent = out.parent().unwrap();
    let stem = out.file_name().unwrap().to_string_lossy().into_owned();
    let leftovers: Vec<String> = listing(parent)
        .into_iter()
        .filter(|n| n.starts_with(&format!(".{stem}.")))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_directory_sph_did_not_write_is_refused_unless_overwrite() {
    let out = scratch("foreign");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("thesis.tex"), "mine").unwrap();
    let result = quick_run(&out, &[]);
    assert_eq!(result.status.code(), Some(2));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("--overwrite") && err.contains("out"), "{err}");
    assert_eq!(listing(&out), ["thesis.tex"]);
    assert!(quick_run(&out, &["--overwrite"]).status.success());
    assert!(!out.join("thesis.tex").exists());
    for root in ["/", "~"] {
        let dir = if root == "~" {
            std::env::var("HOME").unwrap_or_else(|_| "/".into())
        } else {
            root.to_string()
        };
        let result = sph()
            .args(["couette", "--quiet", "--out", &dir])
            .output()
            .unwrap();
        assert_eq!(result.status.code(), Some(2), "{dir}");
        assert!(String::from_utf8_lossy(&result.stderr).contains("home directory"));
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn absurd_values_are_refused_in_one_short_line() {
    // --shift 2e305 used to hang in the plotting code.
    let out = scratch("shift");
    let result = quick_run(&out, &["--shift", "2e305"]);
    assert_eq!(result.status.code(), Some(2));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("`shift`") && err.len() < 300, "{err}");
    assert!(!out.exists());
    // A run that would never end (nu 1e9 times too large: 7.6e12 steps).
    let result = quick_run(&out, &["--nu", "1e3"]);
    assert_eq!(result.status.code(), Some(2));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        err.contains("time steps") && err.contains("--allow-long-run"),
        "{err}"
    );
    assert!(!out.exists());
    // A shorter run needs no output times of its own.
    let result = sph()
        .args([
            "couette",
            "--quiet",
            "--particles-across",
            "16",
            "--t-end",
            "0.05",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_run_with_one_output_time_draws_its_plots() {
    // One output: every plot's time axis is a single value.
    let out = scratch("one-output");
    let result = sph()
        .args([
            "run",
            "taylor-green",
            "--quiet",
            "--resolution",
            "16",
            "--t-end",
            "0.05",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    for name in ["diagnostics.png", "case.png", "summary.json"] {
        assert!(out.join(name).is_file(), "{name}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn no_command_names_the_commands() {
    let result = sph().output().unwrap();
    assert_eq!(result.status.code(), Some(2));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        err.contains("no command given") && err.contains("couette") && err.contains("run"),
        "{err}"
    );
}

/// Starts `sph run` into `out` with a checkpoint every 0.03 s and sends
/// `signal` once its first checkpoint is published.
#[cfg(unix)]
fn interrupt_after_first_checkpoint(out: &Path, signal: &str, threads: &str) -> Option<i32> {
    let mut child = sph()
        .args(RESTART_RUN)
        .args(["--threads", threads, "--checkpoint-every", "0.03", "--out"])
        .arg(out)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let checkpoint = out.join("checkpoint.bin");
    while !checkpoint.exists() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run ended ({status}) before its first checkpoint");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    send(signal, child.id());
    child.wait().unwrap().code()
}

const RESTART_RUN: [&str; 6] = [
    "run",
    "taylor-green",
    "--quiet",
    "--resolution",
    "64",
    "--t-end=0.3",
];

#[cfg(unix)]
#[test]
fn an_interrupted_or_killed_run_resumes_to_the_same_bytes() {
    let whole = scratch("restart-whole");
    let result = sph()
        .args(RESTART_RUN)
        .args(["--threads", "2", "--out"])
        .arg(&whole)
        .output()
        .unwrap();
    assert!(result.status.success(), "{result:?}");
    let expected = std::fs::read(whole.join("particles.csv")).unwrap();
    let outputs = |dir: &Path| {
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        (
            s["outputs"].clone(),
            s["steps"].clone(),
            s["complete"].clone(),
        )
    };
    // SIGINT: stops at a step boundary, publishes with its checkpoint, 130.
    // SIGKILL: the process is gone; the last periodic checkpoint remains.
    for (signal, status, threads) in [("INT", Some(130), "1"), ("KILL", None, "2")] {
        let out = scratch(&format!("restart-{signal}"));
        assert_eq!(
            interrupt_after_first_checkpoint(&out, signal, threads),
            status
        );
        let partial = outputs(&out);
        assert_eq!(partial.2, false, "{signal}");
        let resumed = sph()
            .args(["resume", "--quiet"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(resumed.status.success(), "{signal}: {resumed:?}");
        assert!(
            std::fs::read(out.join("particles.csv")).unwrap() == expected,
            "{signal}: particles.csv differs from the uninterrupted run's"
        );
        assert_eq!(outputs(&out), outputs(&whole), "{signal}");
        // A complete run keeps no checkpoint, and nothing else is left.
        assert!(!out.join("checkpoint.bin").exists());
        let leftovers: Vec<String> = std::fs::read_dir(out.parent().unwrap())
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(&format!("restart-{signal}")) && n.starts_with('.'))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
        let _ = std::fs::remove_dir_all(&out);
    }
    // Nothing to resume in a completed run's directory.
    let again = sph().args(["resume"]).arg(&whole).output().unwrap();
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("checkpoint"));
    let _ = std::fs::remove_dir_all(&whole);
}

/// `sph couette` interrupted by SIGINT publishes its profiles so far with a
/// checkpoint; `sph resume` finishes it with the uninterrupted run's bytes.
#[cfg(unix)]
#[test]
fn an_interrupted_couette_run_resumes_to_the_same_bytes() {
    let args = [
        "couette",
        "--quiet",
        "--particles-across",
        "48",
        "--t-end",
        "4",
        "--output-times",
        "0.1,2,4",
        "--threads",
        "1",
    ];
    let whole = scratch("couette-whole");
    let result = sph().args(args).arg("--out").arg(&whole).output().unwrap();
    assert!(result.status.success(), "{result:?}");
    let out = scratch("couette-int");
    let child = sph()
        .args(args)
        .arg("--out")
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    send("INT", child.id());
    let result = child.wait_with_output().unwrap();
    assert_eq!(
        result.status.code(),
        Some(130),
        "the run ended before the signal: lengthen it ({result:?})"
    );
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("sph resume"), "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], false);
    assert!(out.join("checkpoint.bin").is_file());
    let resumed = sph()
        .args(["resume", "--quiet"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{resumed:?}");
    assert!(
        std::fs::read(out.join("profile.csv")).unwrap()
            == std::fs::read(whole.join("profile.csv")).unwrap(),
        "profile.csv differs from the uninterrupted run's"
    );
    let errors = |dir: &Path| {
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        (
            s["errors"].clone(),
            s["steps"].clone(),
            s["complete"].clone(),
        )
    };
    assert_eq!(errors(&out), errors(&whole));
    assert!(!out.join("checkpoint.bin").exists());
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&whole);
}

/// Runs `sph ARGS` and returns (exit status, stderr).
fn status_and_error(args: &[&str]) -> (Option<i32>, String) {
    let result = sph().args(args).output().unwrap();
    (
        result.status.code(),
        String::from_utf8_lossy(&result.stderr).into_owned(),
    )
}

#[test]
fn runs_too_large_for_memory_are_refused_before_allocating() {
    let out = scratch("huge");
    let dir = out.to_string_lossy().into_owned();
    // About 1e10 particles (a strip 1e8 supports wide): some 8 TiB.
    let (code, err) = status_and_error(&["couette", "--strip-supports", "1e8", "--out", &dir]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("GiB") && err.contains("`particles`"), "{err}");
    // 6e7 particles in the benchmark box: about 26 GiB, where that is more
    // than the machine has (the test must not allocate it elsewhere).
    let available = sph_std::resources::available_memory().unwrap_or(0) as f64;
    if available > 0.0 && available < 25.0 * (1u64 << 30) as f64 {
        let (code, err) = status_and_error(&["bench", "--n", "60000000", "--steps", "1"]);
        assert_eq!(code, Some(2), "{err}");
        assert!(err.contains("`n`") && err.contains("GiB"), "{err}");
    }
    // A million output times, each a profile of every particle.
    let many: Vec<String> = (1..=1_000_000)
        .map(|i| format!("{}", i as f64 * 1e-6))
        .collect();
    let config = out.with_extension("toml");
    std::fs::write(&config, format!("output_times = [{}]\n", many.join(","))).unwrap();
    let (code, err) = status_and_error(&[
        "couette",
        "--config",
        &config.to_string_lossy(),
        "--t-end",
        "1",
        "--out",
        &dir,
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("`output_times`") && err.len() < 300, "{err}");
    assert!(!out.exists());
    let _ = std::fs::remove_file(&config);
}

#[test]
fn benchmark_edge_cases_are_clear_errors_or_work() {
    // Too small for the periodic box: the error states the real minimum.
    for args in [
        &["bench", "--n", "16"][..],
        &["bench", "--n", "30"],
        &["bench", "--scene", "box3d", "--n", "20"],
    ] {
        let (code, err) = status_and_error(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains("`n`") && err.contains("between"), "{err}");
    }
    // The smallest accepted sizes run, and so do wide skins on Couette.
    for args in [
        &["bench", "--n", "36", "--steps", "2", "--warmup", "1"][..],
        &[
            "bench", "--scene", "box3d", "--n", "216", "--steps", "2", "--warmup", "1",
        ],
        &[
            "bench", "--scene", "couette", "--n", "2000", "--skin", "0.4", "--steps", "2",
        ],
        &[
            "bench", "--scene", "couette", "--n", "2000", "--skin", "1", "--steps", "2",
        ],
    ] {
        let (code, err) = status_and_error(args);
        assert_eq!(code, Some(0), "{args:?}: {err}");
    }
    // The fast preset runs its one pass (continuity density in the force
    // pass) and says so; it applies to the box scenes only.
    let result = sph()
        .args([
            "bench", "--preset", "fast", "--n", "36", "--steps", "2", "--warmup", "1", "--json",
        ])
        .output()
        .unwrap();
    assert_eq!(result.status.code(), Some(0));
    let report: serde_json::Value = serde_json::from_slice(&result.stdout).unwrap();
    assert_eq!(report["preset"], "fast");
    assert_eq!(report["density"], "continuity");
    assert_eq!(report["passes_per_step"], 1);
    // A preset off the box scenes or unknown, a NaN skin without lists, a
    // sweep of one size: refused, not NaN output.
    for (args, key) in [
        (
            &["bench", "--preset", "fast", "--scene", "couette"][..],
            "`preset`",
        ),
        (
            &["bench", "--preset", "fast", "--scene", "taylor-green"],
            "`preset`",
        ),
        (&["bench", "--preset", "turbo"], "preset"),
        (&["bench", "--no-lists", "--skin", "NaN"], "`skin`"),
        (&["bench", "--sweep", "--sizes", "100"], "`sizes`"),
        (&["bench", "--sweep", "--sizes", "100,100"], "`sizes`"),
    ] {
        let (code, err) = status_and_error(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(key), "{err}");
    }
}

#[test]
fn a_case_scene_is_timed_as_sph_run_steps_it() {
    let report = |args: &[&str]| -> serde_json::Value {
        let result = sph().args(args).output().unwrap();
        assert!(result.status.success(), "{args:?}: {result:?}");
        serde_json::from_slice(&result.stdout).unwrap()
    };
    let base = [
        "bench",
        "--scene",
        "dam-break",
        "--n",
        "800",
        "--steps",
        "4",
        "--warmup",
        "2",
        "--json",
    ];
    let dam = report(&base);
    assert_eq!(dam["scene"], "dam-break");
    assert_eq!(dam["steps"], 4);
    // The resolution scales with sqrt(n): about 800 fluid particles.
    let n = dam["n"].as_f64().unwrap();
    assert!((500.0..1300.0).contains(&n), "{dam}");
    // Quintic spline, beta 1: support 3 dx, pi 9 = 28.3 neighbours inside the
    // fluid, fewer at the free surface, wall particles counted.
    let k = dam["neighbours_mean"].as_f64().unwrap();
    assert!((14.0..31.0).contains(&k), "{dam}");
    // Continuity density (no density pass), forces, the energy budget's rates.
    assert_eq!(dam["passes_per_step"], 2, "{dam}");
    assert!(dam["particle_steps_per_s"].as_f64().unwrap() > 0.0);
    // The case's settings are the flags of `sph run`.
    let no_budget = report(&[&base[..], &["--energy-budget", "false"]].concat());
    assert_eq!(no_budget["passes_per_step"], 1, "{no_budget}");
    let three = report(&[
        "bench",
        "--scene",
        "dam-break",
        "--dim",
        "3",
        "--resolution",
        "6",
        "--steps",
        "2",
        "--warmup",
        "0",
        "--json",
    ]);
    // 6 x 12 x 6 particles in the column.
    assert_eq!(three["n"], 432, "{three}");
    // Box-scene options, case settings on a box, both sizes: clear errors.
    let toml = scratch("bench-short").with_extension("toml");
    std::fs::write(
        &toml,
        "case = \"dam-break\"\nresolution = 8\nt_end = 0.01\n",
    )
    .unwrap();
    let toml = toml.to_string_lossy().into_owned();
    for (args, key) in [
        (
            &["bench", "--scene", "dam-break", "--shuffle"][..],
            "`shuffle`",
        ),
        (
            &["bench", "--scene", "dam-break", "--skin", "0.3"],
            "`skin`",
        ),
        (
            &["bench", "--scene", "box2d", "--resolution", "10"],
            "`scene`",
        ),
        (
            &[
                "bench",
                "--scene",
                "dam-break",
                "--n",
                "100",
                "--resolution",
                "10",
            ],
            "`n`",
        ),
        (&["bench", "--scene", "no-such-case"], "`case`"),
        (
            &["bench", "--scene", &toml, "--warmup", "100000"],
            "`steps`",
        ),
    ] {
        let (code, err) = status_and_error(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains(key), "{args:?}: {err}");
    }
    let _ = std::fs::remove_file(&toml);
}

/// The texts of the numbers after every `"key":` in a JSON text.
fn numbers_after<'a>(json: &'a str, key: &str) -> Vec<&'a str> {
    let quoted = format!("\"{key}\":");
    json.match_indices(&quoted)
        .map(|(at, _)| {
            let rest = json[at + quoted.len()..].trim_start();
            let end = rest
                .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
                .unwrap_or(rest.len());
            &rest[..end]
        })
        .collect()
}

#[test]
fn json_flags_print_one_object_and_nothing_else_on_stdout() {
    let out = scratch("json");
    let dir = out.to_string_lossy().into_owned();
    let couette = [
        "couette",
        "--particles-across",
        "16",
        "--t-end",
        "0.05",
        "--output-times",
        "0.0225,0.05",
        "--json",
        "--out",
        &dir,
    ];
    let run = [
        "run",
        "poiseuille",
        "--resolution",
        "10",
        "--t-end",
        "0.02",
        "--json",
        "--overwrite",
        "--out",
        &dir,
    ];
    let bench = [
        "bench", "--n", "400", "--steps", "2", "--warmup", "1", "--json",
    ];
    let sweep = [
        "bench", "--sweep", "--sizes", "100,400", "--steps", "2", "--json",
    ];
    // A longer Couette run whose final error, parsed with serde_json's
    // default (fast, not correctly rounded) float parser and printed again,
    // came out one unit in the last place off summary.json's.
    let long = [
        "run",
        "couette",
        "--resolution",
        "40",
        "--re",
        "0.0125",
        "--threads",
        "1",
        "--json",
        "--overwrite",
        "--out",
        &dir,
    ];
    for args in [&couette[..], &run, &long, &bench, &sweep] {
        let result = sph().args(args).output().unwrap();
        assert!(result.status.success(), "{args:?}: {result:?}");
        let stdout = String::from_utf8(result.stdout).unwrap();
        // The whole of stdout parses as one JSON value, an object.
        let value: serde_json::Value = serde_json::from_str(&stdout)
            .unwrap_or_else(|e| panic!("{args:?}: stdout is not one JSON object ({e}): {stdout}"));
        assert!(value.is_object(), "{args:?}");
        // The human text went to stderr.
        assert!(!result.stderr.is_empty(), "{args:?}");
        if args[0] != "bench" {
            // Summaries carry their units, version and time of writing.
            assert_eq!(value["sph_version"], env!("CARGO_PKG_VERSION"));
            assert_eq!(value["units"]["velocity"], "m/s");
            let stamp = value["timestamp"].as_str().unwrap();
            assert!(stamp.len() == 20 && stamp.ends_with('Z'), "{stamp}");
            let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
            let file: serde_json::Value = serde_json::from_str(&text).unwrap();
            assert_eq!(file, value, "{args:?}: stdout is summary.json");
            // Digit for digit: both are the shortest text of the same f64s
            // (equal texts, equal bits, whatever the parser's rounding).
            for key in ["t", "linf", "l2", "kinetic_energy"] {
                assert_eq!(
                    numbers_after(&stdout, key),
                    numbers_after(&text, key),
                    "{args:?}: `{key}`"
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_mistyped_flag_names_the_flag_meant_on_the_same_line() {
    let (code, err) = status_and_error(&["couette", "--particle-across", "5"]);
    assert_eq!(code, Some(2));
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("'--particles-across'"), "{err}");
}
