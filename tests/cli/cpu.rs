//! An x86-64-v3 build on an older processor: the binary says what the CPU lacks instead
//! of dying of an illegal instruction. The old processors are QEMU's user-mode emulation
//! (`qemu-x86_64`, Debian's qemu-user): `.ci/run` installs it and sets
//! `OSMAB_TEST_REQUIRE_QEMU=1`; without it, elsewhere, these tests say so and pass.

use std::process::Command;

/// `osmab --version` on the emulated `cpu`, or None if there is no emulator to run it.
fn version_on(cpu: &str) -> Option<std::process::Output> {
    let emulator = std::env::var("OSMAB_TEST_QEMU").unwrap_or_else(|_| "qemu-x86_64".into());
    match Command::new(&emulator).args(["-cpu", cpu, env!("CARGO_BIN_EXE_osmab"), "--version"]).output() {
        Ok(out) => Some(out),
        Err(e) if std::env::var_os("OSMAB_TEST_REQUIRE_QEMU").is_some() => panic!("{emulator} cannot run ({e}): apt-get install qemu-user"),
        Err(e) => {
            eprintln!("skipped: {emulator} cannot run ({e}); .ci/run installs qemu-user");
            None
        }
    }
}

#[test]
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
fn on_a_cpu_without_avx_the_binary_names_what_it_lacks_and_how_to_build_for_it() {
    let Some(out) = version_on("Nehalem") else { return };
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "expected a clean exit with status 1, not a signal: {err}");
    assert!(err.contains("built for x86-64-v3 processors") && err.contains("this CPU lacks avx\n"), "{err}");
    assert!(err.contains("RUSTFLAGS=\"-C target-cpu=native\" cargo build --release -p osmab"), "{err}");
    assert!(out.stdout.is_empty(), "nothing else ran");
}

#[test]
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
fn on_a_cpu_with_avx_but_not_avx2_the_binary_names_avx2() {
    let Some(out) = version_on("SandyBridge") else { return };
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("this CPU lacks avx2\n"), "{err}");
}

#[test]
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
fn on_a_cpu_with_every_feature_the_binary_runs() {
    let Some(out) = version_on("Haswell") else { return };
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("osmab "));
}
