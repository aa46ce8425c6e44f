//! `cargo xtask`: project automation that plain `cargo build`/`cargo test`
//! cannot do (see matklad/cargo-xtask). Std only, no dependencies.
//!
//! Commands:
//! - `cross`: build sph-core for bare-metal and wasm targets, with default
//!   features and with `fast-math` (installs missing targets with rustup).
//! - `deps`: check that sph-core's normal dependencies are only libm,
//!   heapless and micromath (and what those pull in).
//! - `qemu`: build the firmware (`examples/firmware`, no allocator, no std),
//!   run its reduced Couette case on an emulated Cortex-M4F (mps2-an386,
//!   libm and micromath) and Cortex-M3 (lm3s6965evb), and check every output
//!   line against the same code run on the host, bit for bit.
//! - `size`: the firmware's flash and static RAM, with and without the
//!   simulation and the error reporting, and bytes per particle.
//! - `c-abi`: build sph-ffi's static library, compile `examples/c/couette.c`
//!   and `examples/c/smoke.cpp` with the system's C and C++ compilers, run
//!   them, and check that the C program's Couette state is `sph couette`'s
//!   at the same settings, bit for bit; build sph-ffi-bare for
//!   thumbv7em-none-eabihf (its functions exported, no allocator symbol) and
//!   run `examples/c/bare.c` against its host build.
//! - `web [--screenshot PATH]`: build the browser module (`web/`, wasm32),
//!   serve the page on 127.0.0.1, load it in headless Chromium, and check
//!   the Couette error the page reports after 300 steps against the same
//!   code run natively, bit for bit; with `--screenshot`, keep a picture.
//!   `web --serve` only serves the page.

#[path = "../../examples/firmware/src/scene.rs"]
#[allow(dead_code)]
mod scene;

use std::env;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// Bare-metal and wasm targets the core must build for.
const TARGETS: &[(&str, &str)] = &[
    ("thumbv6m-none-eabi", "Cortex-M0: no FPU, no atomics"),
    ("thumbv7em-none-eabihf", "Cortex-M4F"),
    ("riscv32imac-unknown-none-elf", "RISC-V 32"),
    ("wasm32-unknown-unknown", "wasm"),
];

/// Crates allowed in `cargo tree -p sph-core -e normal`.
const ALLOWED_CORE_DEPS: &[&str] = &[
    "sph-core",
    "libm",
    "heapless",
    "micromath",
    "hash32",
    "byteorder",
    "stable_deref_trait",
];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn cargo() -> Command {
    let mut c = Command::new(env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    c
}

fn fail(msg: String) -> Result<(), String> {
    Err(msg)
}

fn installed_targets() -> Result<String, String> {
    let out = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| format!("cannot run rustup (needed to install targets): {e}"))?;
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn ensure_target(target: &str) -> Result<(), String> {
    if installed_targets()?.lines().any(|l| l.trim() == target) {
        return Ok(());
    }
    eprintln!("xtask: installing target {target} (rustup target add {target})");
    let status = Command::new("rustup")
        .args(["target", "add", target])
        .status()
        .map_err(|e| format!("cannot run rustup: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        fail(format!(
            "target {target}: `rustup target add {target}` failed"
        ))
    }
}

fn cross() -> Result<(), String> {
    for (target, what) in TARGETS {
        ensure_target(target)?;
        for features in [None, Some("fast-math")] {
            let mut cmd = cargo();
            cmd.args([
                "build",
                "--quiet",
                "--release",
                "-p",
                "sph-core",
                "--target",
                target,
            ]);
            if let Some(f) = features {
                cmd.args(["--features", f]);
            }
            let label = format!(
                "{target} ({what}), features: {}",
                features.unwrap_or("default")
            );
            run_build(&mut cmd, &label)?;
            println!("ok  sph-core for {label}");
        }
    }
    Ok(())
}

/// Runs a cargo build; on failure, an error naming `label`, the first
/// `error` line, and the whole of cargo's output.
fn run_build(cmd: &mut Command, label: &str) -> Result<(), String> {
    let out = cmd
        .output()
        .map_err(|e| format!("{label}: cannot run cargo: {e}"))?;
    if out.status.success() {
        return Ok(());
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let first = stderr
        .lines()
        .find(|l| l.starts_with("error"))
        .unwrap_or("build failed");
    fail(format!("{label}: {first}\n{stderr}"))
}

fn deps() -> Result<(), String> {
    let out = cargo()
        .args([
            "tree",
            "-p",
            "sph-core",
            "-e",
            "normal",
            "--prefix",
            "none",
            "--all-features",
        ])
        .output()
        .map_err(|e| format!("cannot run cargo tree: {e}"))?;
    if !out.status.success() {
        return fail(format!(
            "cargo tree failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let tree = String::from_utf8_lossy(&out.stdout);
    let mut bad = Vec::new();
    for line in tree.lines() {
        let name = line.split_whitespace().next().unwrap_or("");
        if !name.is_empty() && !ALLOWED_CORE_DEPS.contains(&name) {
            bad.push(name.to_string());
        }
    }
    if bad.is_empty() {
        println!(
            "ok  sph-core depends only on: {}",
            ALLOWED_CORE_DEPS[1..].join(", ")
        );
        Ok(())
    } else {
        fail(format!(
            "sph-core has dependencies outside libm, heapless, micromath: {}",
            bad.join(", ")
        ))
    }
}

/// A firmware build: target, QEMU CPU and machine, cargo feature arguments.
struct Firmware {
    target: &'static str,
    cpu: &'static str,
    machine: &'static str,
    features: &'static [&'static str],
    backend: &'static str,
}

const RUNS: &[Firmware] = &[
    Firmware {
        target: "thumbv7em-none-eabihf",
        cpu: "cortex-m4",
        machine: "mps2-an386",
        features: &[],
        backend: "libm",
    },
    Firmware {
        target: "thumbv7em-none-eabihf",
        cpu: "cortex-m4",
        machine: "mps2-an386",
        features: &["--features", "fast-math"],
        backend: "micromath",
    },
    Firmware {
        target: "thumbv7m-none-eabi",
        cpu: "cortex-m3",
        machine: "lm3s6965evb",
        features: &[],
        backend: "libm",
    },
];

fn firmware_dir() -> PathBuf {
    root().join("examples").join("firmware")
}

/// Where firmware builds go: an explicit directory, so that neither
/// `CARGO_TARGET_DIR` nor the firmware's own workspace decides where the
/// image lands (and a stale image elsewhere is never run).
fn firmware_target_dir() -> PathBuf {
    root().join("target").join("firmware")
}

/// Builds the firmware and returns the path of the ELF image.
fn build_firmware(target: &str, features: &[&str]) -> Result<PathBuf, String> {
    ensure_target(target)?;
    let mut cmd = Command::new(env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.current_dir(firmware_dir())
        .args(["build", "--quiet", "--release", "--target", target])
        .arg("--target-dir")
        .arg(firmware_target_dir())
        .args(features);
    run_build(&mut cmd, &format!("firmware for {target} {features:?}"))?;
    let elf = firmware_target_dir()
        .join(target)
        .join("release")
        .join("sph-firmware");
    if !elf.is_file() {
        return Err(format!(
            "firmware for {target}: built, but {} is missing",
            elf.display()
        ));
    }
    Ok(elf)
}

fn qemu() -> Result<(), String> {
    if Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .is_err()
    {
        return fail(
            "qemu-system-arm not found. On Debian bookworm: add bookworm-backports to the Suites of \
             /etc/apt/sources.list.d/debian.sources, apt-get update, and apt-get install -y \
             --no-install-recommends -t bookworm-backports qemu-system-arm"
                .into(),
        );
    }
    let mut host = std::collections::HashMap::new();
    for backend in ["libm", "micromath"] {
        let out = cargo()
            .args([
                "run",
                "--quiet",
                "-p",
                "sph-core",
                "--release",
                "--example",
                "firmware_host",
                "--",
                backend,
            ])
            .output()
            .map_err(|e| format!("cannot run the host reference: {e}"))?;
        if !out.status.success() {
            return fail(format!(
                "host reference ({backend}) failed: {}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let lines: Vec<String> = String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.starts_with("t_ms="))
            .map(String::from)
            .collect();
        host.insert(backend, lines);
    }
    for run in RUNS {
        let elf = build_firmware(run.target, run.features)?;
        let label = format!(
            "{} on {} ({}), {}",
            run.target, run.machine, run.cpu, run.backend
        );
        let out = Command::new("timeout")
            .args([
                "120",
                "qemu-system-arm",
                "-cpu",
                run.cpu,
                "-machine",
                run.machine,
                "-nographic",
            ])
            .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
            .arg(&elf)
            .output()
            .map_err(|e| format!("{label}: cannot run qemu: {e}"))?;
        let stdout = String::from_utf8_lossy(&out.stdout);
        print!("{label}:\n{stdout}");
        if !out.status.success() {
            return fail(format!(
                "{label}: firmware exited with {:?} (124: timeout)\n{}",
                out.status.code(),
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with("t_ms=")).collect();
        let reference = &host[run.backend];
        if lines.len() != reference.len()
            || lines.iter().zip(reference).any(|(a, b)| *a != b.as_str())
        {
            return fail(format!("{label}: output differs from the host's:\n  firmware: {lines:?}\n  host:     {reference:?}"));
        }
        println!("ok  {label}: every line equals the host's, bit for bit");
    }
    Ok(())
}

/// Sizes of the allocated sections of a 32-bit little-endian ELF file.
fn sections(path: &Path) -> Result<Vec<(String, u64, u32)>, String> {
    let data = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let u16_at = |o: usize| {
        data.get(o..o + 2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]) as usize)
    };
    let u32_at = |o: usize| {
        data.get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let bad = || format!("{}: not a 32-bit little-endian ELF file", path.display());
    if data.get(0..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err(bad());
    }
    let shoff = u32_at(0x20).ok_or_else(bad)? as usize;
    let shentsize = u16_at(0x2e).ok_or_else(bad)?;
    let shnum = u16_at(0x30).ok_or_else(bad)?;
    let shstrndx = u16_at(0x32).ok_or_else(bad)?;
    let header = |k: usize| shoff + k * shentsize;
    let strtab = u32_at(header(shstrndx) + 0x10).ok_or_else(bad)? as usize;
    let mut out = Vec::new();
    for k in 0..shnum {
        let h = header(k);
        let name_off = u32_at(h).ok_or_else(bad)? as usize;
        let sh_type = u32_at(h + 4).ok_or_else(bad)?;
        let flags = u32_at(h + 8).ok_or_else(bad)?;
        let size = u32_at(h + 0x14).ok_or_else(bad)?;
        let name_bytes = data.get(strtab + name_off..).ok_or_else(bad)?;
        let end = name_bytes.iter().position(|&b| b == 0).unwrap_or(0);
        let name = String::from_utf8_lossy(&name_bytes[..end]).into_owned();
        // SHF_ALLOC: the section occupies memory on the target.
        if flags & 2 != 0 {
            out.push((name, u64::from(size), sh_type));
        }
    }
    Ok(out)
}

/// (flash, static RAM) of an image: flash holds code, constants and the
/// initial values of .data; RAM holds .data, .bss and .uninit.
fn flash_and_ram(path: &Path) -> Result<(u64, u64), String> {
    let mut flash = 0;
    let mut ram = 0;
    for (name, size, sh_type) in sections(path)? {
        let nobits = sh_type == 8;
        if name == ".data" {
            flash += size;
            ram += size;
        } else if nobits {
            ram += size;
        } else {
            flash += size;
        }
    }
    Ok((flash, ram))
}

fn size() -> Result<(), String> {
    let target = "thumbv7em-none-eabihf";
    let variants: &[(&str, &[&str])] = &[
        ("bare firmware (no simulation)", &["--no-default-features"]),
        (
            "simulation, libm, silent",
            &["--no-default-features", "--features", "sim"],
        ),
        ("simulation, libm, with error report", &[]),
        (
            "simulation, fast-math, silent",
            &["--no-default-features", "--features", "sim,fast-math"],
        ),
        (
            "simulation, fast-math, with error report",
            &["--features", "fast-math"],
        ),
    ];
    let mut rows = Vec::new();
    for (label, features) in variants {
        let elf = build_firmware(target, features)?;
        let (flash, ram) = flash_and_ram(&elf)?;
        rows.push((*label, flash, ram));
    }
    println!("Firmware for {target} (Cortex-M4F), opt-level s, LTO:");
    println!(
        "{:<42} {:>12} {:>16}",
        "variant", "flash [B]", "static RAM [B]"
    );
    for (label, flash, ram) in &rows {
        println!("{label:<42} {flash:>12} {ram:>16}");
    }
    let (base_flash, base_ram) = (rows[0].1, rows[0].2);
    println!();
    println!(
        "The core's Couette step (libm):      {:>6} B flash, {:>6} B static RAM (simulation minus bare firmware)",
        rows[1].1 - base_flash,
        rows[1].2 - base_ram
    );
    println!(
        "The core's Couette step (fast-math): {:>6} B flash, {:>6} B static RAM",
        rows[3].1 - base_flash,
        rows[3].2 - base_ram
    );
    println!(
        "Reporting (exact series, semihosting, integer formatting, panic messages): {} B flash",
        rows[2].1 - rows[1].1
    );
    println!(
        "Storage: {} B per particle slot (f32, 2D, no neighbour lists); the scene's store holds {} slots and {} cell starts in {} B",
        sph_core::solver::bytes_per_particle::<sph_core::space::D2<f32>>(),
        scene::SLOTS,
        scene::CELLS,
        std::mem::size_of::<scene::SceneStore>()
    );
    Ok(())
}

/// The workspace's target directory.
fn target_dir() -> PathBuf {
    env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"))
}

/// Runs a program to completion; its stdout, or an error with its output.
fn run_program(cmd: &mut Command, label: &str) -> Result<String, String> {
    let out = cmd
        .output()
        .map_err(|e| format!("{label}: cannot start it: {e}"))?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() {
        return fail(format!(
            "{label} failed ({}):\n{stdout}{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ))
        .map(|_| String::new());
    }
    Ok(stdout)
}

/// Every number that follows `key` in `text`, in order.
fn numbers_after(text: &str, key: &str) -> Result<Vec<f64>, String> {
    text.match_indices(key)
        .map(|(at, _)| {
            let rest = text[at + key.len()..].trim_start();
            let end = rest
                .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
                .unwrap_or(rest.len());
            rest[..end]
                .parse::<f64>()
                .map_err(|e| format!("`{key}` followed by `{}`: {e}", &rest[..end]))
        })
        .collect()
}

/// The bare-metal C library for a Cortex-M4F: it builds, exports the
/// header's functions, and holds no allocator symbol.
fn bare_metal() -> Result<(), String> {
    let target = "thumbv7em-none-eabihf";
    ensure_target(target)?;
    run_build(
        cargo().args([
            "build",
            "--release",
            "-p",
            "sph-ffi-bare",
            "--target",
            target,
        ]),
        "sph-ffi-bare (thumbv7em)",
    )?;
    let lib = target_dir()
        .join(target)
        .join("release")
        .join("libsph_bare.a");
    let symbols = run_program(Command::new("nm").arg(&lib), "nm libsph_bare.a")?;
    let exported = symbols
        .lines()
        .filter(|l| l.contains(" T sph_bare_"))
        .count();
    let header = std::fs::read_to_string(root().join("sph-ffi/bare/include/sph_bare.h"))
        .map_err(|e| format!("sph_bare.h: {e}"))?;
    let declared = header.matches(" sph_bare_").count();
    if exported == 0 || exported != declared {
        return fail(format!(
            "libsph_bare.a ({target}) exports {exported} sph_bare_ functions, the header declares {declared}"
        ));
    }
    if let Some(line) = symbols.lines().find(|l| l.contains("alloc")) {
        return fail(format!(
            "libsph_bare.a ({target}) holds an allocator symbol: {line}"
        ));
    }
    let bytes = std::fs::metadata(&lib).map(|m| m.len()).unwrap_or(0);
    println!(
        "libsph_bare.a for {target}: {exported} functions, no allocator symbol ({bytes} bytes with its libraries)"
    );
    Ok(())
}

/// The test profile over the whole workspace with its tests selected: the
/// same feature resolution as `cargo test --workspace`, so every artifact
/// of the test command is reused (selecting single packages resolves
/// features differently and compiles sph-std again).
fn workspace_build() -> Result<(), String> {
    run_build(
        cargo().args([
            "build",
            "--profile",
            "test",
            "--workspace",
            "--lib",
            "--bins",
            "--tests",
        ]),
        "the workspace's libraries and binaries",
    )
}

fn c_abi() -> Result<(), String> {
    workspace_build()?;
    bare_metal()?;
    let target = target_dir();
    let lib = target.join("debug").join("libsph_ffi.a");
    let out = target.join("c-abi");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let include = root().join("sph-ffi").join("include");
    // Rust's standard library needs these from the system (`cargo rustc
    // --print native-static-libs` lists them).
    let system = ["-lpthread", "-ldl", "-lm"];
    for (compiler, source, standard, exe) in [
        ("CC", "couette.c", "-std=c99", "couette"),
        ("CXX", "smoke.cpp", "-std=c++17", "smoke"),
    ] {
        let default = if compiler == "CC" { "cc" } else { "c++" };
        let cc = env::var(compiler).unwrap_or_else(|_| default.into());
        let mut cmd = Command::new(&cc);
        cmd.args([standard, "-O2", "-Wall", "-Wextra", "-Werror"])
            .arg(root().join("examples").join("c").join(source))
            .arg("-I")
            .arg(&include)
            .arg(&lib)
            .args(system)
            .arg("-o")
            .arg(out.join(exe));
        run_program(&mut cmd, &format!("{cc} {source}"))?;
    }
    print!(
        "{}",
        run_program(&mut Command::new(out.join("smoke")), "smoke")?
    );
    let bare = out.join("bare");
    run_program(
        Command::new(env::var("CC").unwrap_or_else(|_| "cc".into()))
            .args(["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror"])
            .arg(root().join("examples/c/bare.c"))
            .arg("-I")
            .arg(root().join("sph-ffi/bare/include"))
            .arg(target.join("debug").join("libsph_bare.a"))
            .args(system)
            .arg("-o")
            .arg(&bare),
        "cc bare.c",
    )?;
    print!("{}", run_program(&mut Command::new(&bare), "bare")?);
    // Settings that no test uses: 16 across to t = 0.15 s.
    let (across, t_end) = (16, 0.15);
    let csv = out.join("couette-final.csv");
    let c = run_program(
        Command::new(out.join("couette"))
            .args([across.to_string(), format!("{t_end:?}")])
            .arg(&csv),
        "couette (C)",
    )?;
    print!("{c}");
    let dir = out.join("sph-couette");
    let _ = std::fs::remove_dir_all(&dir);
    let times = format!("{:?},{:?},{:?}", t_end / 4.0, t_end / 2.0, t_end);
    let sph = target.join("debug").join("sph");
    let summary = run_program(
        Command::new(&sph)
            .args(["couette", "--particles-across", &across.to_string()])
            .args(["--t-end", &format!("{t_end:?}"), "--output-times", &times])
            .args(["--threads", "1", "--quiet", "--json", "--out"])
            .arg(&dir),
        "sph couette",
    )?;
    // The state: every particle's y and u at the end, bit for bit.
    let read =
        |path: &Path| std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()));
    let rows = |text: &str, skip: usize| -> Result<Vec<(f64, f64)>, String> {
        text.lines()
            .skip(1)
            .map(|line| {
                let cols: Vec<f64> = line
                    .split(',')
                    .map(|c| c.parse::<f64>().map_err(|e| format!("`{line}`: {e}")))
                    .collect::<Result<_, _>>()?;
                Ok((cols[skip], cols[skip + 1]))
            })
            .collect()
    };
    let from_c = rows(&read(&csv)?, 0)?;
    let profile = read(&dir.join("profile.csv"))?;
    // profile.csv: t,y,vx,vx_exact at every output time; the last time's rows.
    let last: String = profile
        .lines()
        .filter(|l| l.starts_with(&format!("{t_end:?},")) || l.starts_with(&format!("{t_end},")))
        .fold(String::from("t,y,vx\n"), |acc, l| acc + l + "\n");
    let from_cli = rows(&last, 1)?;
    if from_c.is_empty() || from_c != from_cli {
        return fail(format!(
            "the C program's final state ({} particles) is not sph couette's ({} rows at t = {t_end})",
            from_c.len(),
            from_cli.len()
        ));
    }
    println!(
        "state at t = {t_end} s through the C ABI: {} particles, sph couette's bit for bit",
        from_c.len()
    );
    // The errors in u: the C program's own series against sph couette's
    // (two implementations of the series: agreement to round-off).
    for (key, json) in [("linf_u", "\"linf\":"), ("l2_u", "\"l2\":")] {
        let c_value = numbers_after(&c, &format!(" {key} "))?;
        let cli = numbers_after(&summary, json)?;
        let (Some(&a), Some(&b)) = (c_value.first(), cli.last()) else {
            return fail(format!("no {key} figure in the outputs"));
        };
        if (a - b).abs() > 1e-9 * b || a.is_nan() {
            return fail(format!(
                "{key}: the C program's {a:e} against sph couette's {b:e}"
            ));
        }
        println!("{key} at t = {t_end} s: C series {a:.10e}, sph couette {b:.10e}");
    }
    Ok(())
}

/// The browser's run, as the page's query: Taylor-Green at 24 across to
/// t = 0.2 (Re 100: the vortex decays by 80 %; about 150 steps).
const WEB_RUN: &str = "run=end&case=taylor-green&resolution=24&re=100&t_end=0.2";

fn web() -> Result<(), String> {
    let args: Vec<String> = env::args().skip(2).collect();
    let serve_only = args.iter().any(|a| a == "--serve");
    let screenshot = args
        .iter()
        .position(|a| a == "--screenshot")
        .map(|k| args.get(k + 1).cloned().ok_or("--screenshot needs a path"))
        .transpose()?;
    ensure_target("wasm32-unknown-unknown")?;
    // Without --serve the page is checked against `sph run`.
    if !serve_only {
        workspace_build()?;
    }
    run_build(
        cargo().args([
            "build",
            "--profile",
            "wasm",
            "--target",
            "wasm32-unknown-unknown",
            "-p",
            "sph-web",
        ]),
        "sph-web (wasm32)",
    )?;
    let target = target_dir();
    let module = target.join("wasm32-unknown-unknown/wasm/sph_web.wasm");
    let site = target.join("web");
    std::fs::create_dir_all(&site).map_err(|e| format!("{}: {e}", site.display()))?;
    for (from, to) in [
        (root().join("web/index.html"), "index.html"),
        (root().join("web/app.js"), "app.js"),
        (module.clone(), "sph_web.wasm"),
    ] {
        std::fs::copy(&from, site.join(to)).map_err(|e| format!("{}: {e}", from.display()))?;
    }
    let bytes = std::fs::metadata(&module).map(|m| m.len()).unwrap_or(0);
    println!("wasm module: {bytes} bytes ({})", module.display());
    // A static server on a free loopback port (it prints the port).
    let mut server = Command::new("python3")
        .args([
            "-u",
            "-m",
            "http.server",
            "0",
            "--bind",
            "127.0.0.1",
            "--directory",
        ])
        .arg(&site)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .map_err(|e| format!("python3 -m http.server: {e}"))?;
    let mut first = String::new();
    if let Some(out) = server.stdout.take() {
        use std::io::BufRead;
        std::io::BufReader::new(out)
            .read_line(&mut first)
            .map_err(|e| format!("http.server: {e}"))?;
    }
    let port = first
        .split_whitespace()
        .skip_while(|w| *w != "port")
        .nth(1)
        .map(str::to_owned)
        .ok_or_else(|| format!("http.server printed `{}`, no port", first.trim()))?;
    let base = format!("http://127.0.0.1:{port}/");
    let outcome = if serve_only {
        println!("serving {base} (Ctrl-C stops)");
        server.wait().map(|_| ()).map_err(|e| e.to_string())
    } else {
        check_page(&base, screenshot.as_deref())
    };
    let _ = server.kill();
    let _ = server.wait();
    outcome
}

/// Loads the page's fixed run in headless Chromium, then runs the scene
/// file the page shows with `sph run` and compares the errors.
fn check_page(base: &str, screenshot: Option<&str>) -> Result<(), String> {
    let url = format!("{base}?{WEB_RUN}");
    let browser = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| Command::new(b).arg("--version").output().is_ok())
        .ok_or("no chromium: install Debian's chromium package")?;
    let profile = target_dir().join("web-profile");
    let _ = std::fs::remove_dir_all(&profile);
    let chromium = |extra: &[String], url: &str| {
        let mut c = Command::new(browser);
        // As root Chromium needs --no-sandbox; the rest keeps it off the
        // network it cannot reach.
        c.args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--virtual-time-budget=60000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(url);
        c
    };
    let dom = run_program(
        &mut chromium(&["--dump-dom".into()], &url),
        "chromium --dump-dom",
    )?;
    let element = |id: &str| -> Option<String> {
        let attribute = format!("id=\"{id}\"");
        let at = dom.find(&attribute)? + attribute.len();
        let text = dom[at..].split_once('>')?.1.split('<').next()?;
        Some(
            text.replace("&quot;", "\"")
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&amp;", "&"),
        )
    };
    if element("status").as_deref() != Some("done") {
        return fail(format!(
            "the page did not finish its run: status `{}`",
            element("status").unwrap_or_default()
        ));
    }
    let page: f64 = element("linf")
        .ok_or("no linf in the page")?
        .parse()
        .map_err(|e| format!("the page's linf: {e}"))?;
    let scene = element("scene").ok_or("no scene text in the page")?;
    let steps = element("steps").unwrap_or_default();
    // The same scene file through the command line (the test profile's
    // binary, built above).
    let out = target_dir().join("web-native");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let file = out.join("scene.toml");
    std::fs::write(&file, &scene).map_err(|e| format!("{}: {e}", file.display()))?;
    run_program(
        Command::new(target_dir().join("debug").join("sph"))
            .arg("run")
            .arg(&file)
            .args(["--quiet", "--out"])
            .arg(out.join("run")),
        "sph run",
    )?;
    let path = out.join("run").join("summary.json");
    let summary = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    // summary.json's outputs are in time order: the last linf is the end's.
    let native = numbers_after(&summary, "\"linf\":")?
        .last()
        .copied()
        .ok_or("no linf from sph run")?;
    let native_steps = numbers_after(&summary, "\"steps\":")?
        .first()
        .copied()
        .unwrap_or(f64::NAN);
    println!(
        "{}: page {page:e} after {steps} steps (rate {} particle-steps/s), sph run {native:e} after {native_steps} steps",
        scene.lines().collect::<Vec<_>>().join("; "),
        element("rate").unwrap_or_default()
    );
    if page.to_bits() != native.to_bits() {
        return fail(format!(
            "the page's error {page:e} is not sph run's {native:e}"
        ));
    }
    println!("the page's error is sph run's, bit for bit");
    if let Some(path) = screenshot {
        let path = std::path::absolute(path).map_err(|e| format!("{path}: {e}"))?;
        // The live page (a few seconds of virtual time), not the fixed run.
        run_program(
            &mut chromium(
                &[
                    format!("--screenshot={}", path.display()),
                    "--window-size=1100,800".into(),
                ],
                base,
            ),
            "chromium --screenshot",
        )?;
        println!("screenshot: {}", path.display());
    }
    Ok(())
}

fn main() -> ExitCode {
    let task = env::args().nth(1).unwrap_or_default();
    let result = match task.as_str() {
        "cross" => cross(),
        "deps" => deps(),
        "qemu" => qemu(),
        "size" => size(),
        "c-abi" => c_abi(),
        "web" => web(),
        _ => {
            eprintln!("usage: cargo xtask <cross|deps|qemu|size|c-abi|web>");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask {task}: error: {e}");
            ExitCode::FAILURE
        }
    }
}
