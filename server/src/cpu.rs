//! The processor features this binary was compiled to use. On x86-64 the workspace
//! builds for x86-64-v3 (`.cargo/config.toml`), and on a CPU without those features the
//! first such instruction would stop the process with SIGILL and no word of why: `osmab`
//! asks the CPU first and says what is missing and how to build for it instead.
//!
//! Code compiled for x86-64-v3 may use its instructions anywhere, even in integer code
//! (an `andn` combining booleans, a `shlx` for a shift), so the check is kept to what
//! compiles to the baseline's instructions: CPUID, then one test and branch per
//! feature bit, and the message written by standard-library code, which is compiled for
//! the baseline. `is_x86_feature_detected!` cannot serve: it answers true without asking
//! for every feature the build enables. Checked by running the binary under
//! `qemu-x86_64 -cpu Nehalem` (no AVX) and `-cpu SandyBridge` (AVX, no AVX2).

use std::io::Write;

/// The first x86-64-v3 feature this build uses that the CPU lacks.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
fn first_missing_feature() -> Option<&'static str> {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    // Leaf 1 ECX: FMA bit 12, MOVBE 22, OSXSAVE 27 (the operating system saves the vector
    // registers, which AVX needs), AVX 28, F16C 29. Leaf 7 EBX: BMI1 bit 3, AVX2 5, BMI2 8.
    // Leaf 0x8000_0001 ECX: LZCNT bit 5.
    let basic = __cpuid(1).ecx;
    let extended = if __cpuid(0).eax >= 7 { __cpuid_count(7, 0).ebx } else { 0 };
    let amd_extended = if __cpuid(0x8000_0000).eax >= 0x8000_0001 { __cpuid(0x8000_0001).ecx } else { 0 };
    if cfg!(target_feature = "avx") && basic & (1 << 28) == 0 {
        return Some("avx");
    }
    if cfg!(target_feature = "avx") && basic & (1 << 27) == 0 {
        return Some("avx (the operating system does not enable it)");
    }
    if cfg!(target_feature = "avx2") && extended & (1 << 5) == 0 {
        return Some("avx2");
    }
    if cfg!(target_feature = "fma") && basic & (1 << 12) == 0 {
        return Some("fma");
    }
    if cfg!(target_feature = "f16c") && basic & (1 << 29) == 0 {
        return Some("f16c");
    }
    if cfg!(target_feature = "bmi1") && extended & (1 << 3) == 0 {
        return Some("bmi1");
    }
    if cfg!(target_feature = "bmi2") && extended & (1 << 8) == 0 {
        return Some("bmi2");
    }
    if cfg!(target_feature = "lzcnt") && amd_extended & (1 << 5) == 0 {
        return Some("lzcnt");
    }
    if cfg!(target_feature = "movbe") && basic & (1 << 22) == 0 {
        return Some("movbe");
    }
    None
}

#[cfg(not(target_arch = "x86_64"))]
fn first_missing_feature() -> Option<&'static str> {
    None
}

/// Stop the process with a message naming a missing feature if the CPU lacks one this
/// build uses. Call it first thing in `main`.
pub fn require_build_features() {
    if let Some(feature) = first_missing_feature() {
        let mut err = std::io::stderr().lock();
        let _ = err.write_all(b"error: this osmab was built for x86-64-v3 processors (AVX2, FMA, BMI1/2, LZCNT, MOVBE, F16C), and this CPU lacks ");
        let _ = err.write_all(feature.as_bytes());
        let _ = err.write_all(
            b"\nbuild it for this CPU with: RUSTFLAGS=\"-C target-cpu=native\" cargo build --release -p osmab\n\
              (or target-cpu=x86-64 for any x86-64 processor)\n",
        );
        drop(err);
        std::process::exit(1);
    }
}
