//! Whether the running processor has the instruction-set features this build of `osmab`
//! was compiled for. On x86-64 the workspace builds for x86-64-v3 (`.cargo/config.toml`),
//! and on a CPU without those features the first such instruction would stop the process
//! with SIGILL and no word of why: `osmab` asks the CPU first and says what is missing and
//! how to build for it instead.
//!
//! Code compiled for x86-64-v3 may use its instructions anywhere, even in integer code: an
//! `andn` to combine booleans, a `shlx` for a shift. The check is therefore kept to what
//! compiles to the baseline's instructions: CPUID, then one test and branch per feature
//! bit. That is a property of the compiled code, not of the source. It is checked by
//! running the binary under `qemu-x86_64 -cpu Nehalem` (no AVX) and `-cpu SandyBridge`
//! (AVX, no AVX2) in the CLI tests (`tests/cli/cpu.rs`). This crate has a crate of its own
//! so that it is compiled optimised in the test profile too (the root `Cargo.toml`): the
//! tests then run the code as it ships. `is_x86_feature_detected!` cannot serve here: it
//! answers true, without asking, for every feature the build enables.
//!
//! Scope: the features of x86-64-v3. A build for a wider target (`-C target-cpu=native` on
//! an AVX-512 machine) is not checked beyond them. The operating system's support for
//! AVX is taken from OSXSAVE, the bit saying it has enabled XSAVE. The full check, XCR0
//! through `xgetbv`, needs `unsafe`, which the workspace forbids.

use std::io::Write;

/// The first feature of x86-64-v3 that this build uses and the CPU lacks.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
fn first_missing_feature() -> Option<&'static str> {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    // Leaf 1 ECX: SSE3 bit 0, SSSE3 9, FMA 12, CMPXCHG16B 13, SSE4.1 19, SSE4.2 20, MOVBE 22,
    // POPCNT 23, XSAVE 26, OSXSAVE 27 (the operating system has enabled XSAVE, which saves
    // the AVX registers), AVX 28, F16C 29. Leaf 7 EBX: BMI1 bit 3, AVX2 5, BMI2 8.
    // Leaf 0x8000_0001 ECX: LAHF/SAHF bit 0, LZCNT 5.
    let basic = __cpuid(1).ecx;
    let extended = if __cpuid(0).eax >= 7 { __cpuid_count(7, 0).ebx } else { 0 };
    let amd_extended = if __cpuid(0x8000_0000).eax >= 0x8000_0001 { __cpuid(0x8000_0001).ecx } else { 0 };
    // The headline features first: a CPU without AVX lacks more, and says so by AVX.
    if cfg!(target_feature = "avx") && basic & (1 << 28) == 0 {
        return Some("avx");
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
    if cfg!(target_feature = "sse3") && basic & (1 << 0) == 0 {
        return Some("sse3");
    }
    if cfg!(target_feature = "ssse3") && basic & (1 << 9) == 0 {
        return Some("ssse3");
    }
    if cfg!(target_feature = "sse4.1") && basic & (1 << 19) == 0 {
        return Some("sse4.1");
    }
    if cfg!(target_feature = "sse4.2") && basic & (1 << 20) == 0 {
        return Some("sse4.2");
    }
    if cfg!(target_feature = "popcnt") && basic & (1 << 23) == 0 {
        return Some("popcnt");
    }
    if cfg!(target_feature = "cmpxchg16b") && basic & (1 << 13) == 0 {
        return Some("cmpxchg16b");
    }
    if cfg!(target_feature = "lahfsahf") && amd_extended & (1 << 0) == 0 {
        return Some("lahfsahf");
    }
    if cfg!(target_feature = "xsave") && basic & (1 << 26) == 0 {
        return Some("xsave");
    }
    if cfg!(target_feature = "avx") && basic & (1 << 27) == 0 {
        return Some("avx (the operating system has not enabled XSAVE)");
    }
    None
}

#[cfg(not(target_arch = "x86_64"))]
fn first_missing_feature() -> Option<&'static str> {
    None
}

/// Stop the process, with a message naming a missing feature and how to build for this
/// CPU, if the CPU lacks one this build uses. Call it first thing in `main`.
#[inline(never)]
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
