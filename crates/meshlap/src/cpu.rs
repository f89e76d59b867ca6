//! The one place that decides which build of meshlap's own SIMD kernels runs: AVX-512,
//! AVX2 + FMA, or the portable one.
//!
//! The kernels are written once, as portable Rust (some with AVX2 intrinsics in a
//! `Kernel::avx2_fma` variant), and compiled three times by `dispatch`: for the
//! baseline x86-64 target (SSE2), with `#[target_feature(enable = "avx2,fma")]`, and
//! with AVX-512 (`avx512f`, `avx512vl`, `avx512dq`, `avx512bw`) added to those, where
//! LLVM vectorises the portable loops over 512-bit registers (the AVX2 intrinsics stay
//! what they are). The kernels: the thin products of the Krylov–Schur eigensolver
//! (`spectral::thin_products`), the codec's dense eigensolver (`spectral::dense_evd`,
//! `spectral::factored_evd`, bit-identical on every build; in the AVX2 and AVX-512
//! builds the inverse iteration's and the QL iteration's row steps are intrinsics,
//! the same IEEE operations per lane as the portable steps), the codec's predictor,
//! the blocked reduction's symmetric products and its divide and conquer's secular
//! equation, eigenvector and leaf kernels (`spectral::tridiagonal_dc`; the secular
//! sums and the eigenvectors' normalisation are AVX2 intrinsics), the geometric
//! operators' per-face lanes, the SDL's row weights, the sparse assembly's one-ring
//! merge and two-ring sort (`operator::assemble`, AVX2 intrinsics gated by
//! [`avx2_fma`]) and the shift-invert solves of the
//! partial eigensolver (`spectral::partial::solve`; its solve without a tree split has
//! an AVX2 build of its own and no AVX-512 one).
//!
//! **Same bits.** Rust keeps IEEE semantics whatever the target features: no build
//! reassociates a sum or fuses a multiply and an add the source does not fuse
//! (`mul_add` is correctly rounded in hardware and in the C library's `fma`), so the
//! AVX-512 build changes how many lanes run at once, never a result of the AVX2 one.
//! The codec's kernels and the geometric operators' lanes are the same bits on the
//! portable build too (tested: `meshlap-cli`'s `tests/portable.rs` compresses, decodes
//! and assembles on all three builds and compares the bytes); the thin products'
//! portable build rounds each product before the add, as `thin_products` says, so
//! the eigensolvers differ from it at rounding level.
//!
//! [`avx2_fma`] and [`avx512`] say which build runs: the CPU's features, detected once,
//! unless the environment says otherwise when the process first asks (read once and
//! cached):
//! - **`MESHLAP_PORTABLE`** set to anything but `0` or the empty string forces the
//!   portable build everywhere — so that tests, and a user who suspects a SIMD path,
//!   can run the code a CPU without AVX2/FMA runs;
//! - **`MESHLAP_NO_AVX512`**, likewise, stops at the AVX2 + FMA build — the code a CPU
//!   without AVX-512 runs.
//!
//! faer's own kernels (through `pulp`) pick their instruction set by themselves and are
//! not affected; the `.mlz` codec does not use them for anything it decodes (see
//! `codec::spectral`).

use std::sync::OnceLock;

/// Name of the environment variable that forces the portable kernels.
pub const PORTABLE_ENV: &str = "MESHLAP_PORTABLE";

/// Name of the environment variable that keeps the kernels off their AVX-512 build.
pub const NO_AVX512_ENV: &str = "MESHLAP_NO_AVX512";

/// Whether the environment variable `name` is set to anything but `0` or empty.
fn env_flag(name: &str) -> bool {
    std::env::var_os(name).is_some_and(|v| !v.is_empty() && v != "0")
}

/// Whether `MESHLAP_PORTABLE` asks for the portable kernels (read once per process).
pub fn portable_forced() -> bool {
    static FORCED: OnceLock<bool> = OnceLock::new();
    *FORCED.get_or_init(|| env_flag(PORTABLE_ENV))
}

/// Whether `MESHLAP_NO_AVX512` keeps the kernels off AVX-512 (read once per process).
pub fn avx512_forbidden() -> bool {
    static FORBIDDEN: OnceLock<bool> = OnceLock::new();
    *FORBIDDEN.get_or_init(|| env_flag(NO_AVX512_ENV))
}

/// Whether the CPU has AVX2 and FMA (detected once), regardless of
/// `MESHLAP_PORTABLE`.
pub fn cpu_has_avx2_fma() -> bool {
    static HAS: OnceLock<bool> = OnceLock::new();
    *HAS.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    })
}

/// Whether the CPU has the AVX-512 subsets the AVX-512 build is compiled for
/// (foundation, vector length, doubleword/quadword and byte/word instructions; detected
/// once), regardless of the environment.
pub fn cpu_has_avx512() -> bool {
    static HAS: OnceLock<bool> = OnceLock::new();
    *HAS.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl")
                && std::arch::is_x86_feature_detected!("avx512dq")
                && std::arch::is_x86_feature_detected!("avx512bw")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    })
}

/// Whether meshlap's kernels run with AVX2 + FMA (their AVX2 build, or the AVX-512 one,
/// which includes both): the CPU has both features and `MESHLAP_PORTABLE` is not set.
/// Callers may only enter a function compiled with
/// `#[target_feature(enable = "avx2,fma")]` when this is true.
pub fn avx2_fma() -> bool {
    cpu_has_avx2_fma() && !portable_forced()
}

/// Whether meshlap's kernels run their AVX-512 build: [`avx2_fma`], the CPU has the
/// subsets of [`cpu_has_avx512`], and `MESHLAP_NO_AVX512` is not set.
pub fn avx512() -> bool {
    avx2_fma() && cpu_has_avx512() && !avx512_forbidden()
}

/// The build meshlap's kernel dispatch runs: `"avx512"`, `"avx2+fma"` or `"portable"`
/// (for reports).
pub fn build_name() -> &'static str {
    if avx512() {
        "avx512"
    } else if avx2_fma() {
        "avx2+fma"
    } else {
        "portable"
    }
}

/// A kernel with an AVX2 + FMA build (also compiled with AVX-512) and a portable one
/// (see [`dispatch`]).
pub(crate) trait Kernel {
    /// What the kernel returns.
    type Output;
    /// The kernel for the baseline target; [`dispatch`] also calls it, inlined into a
    /// function compiled with AVX2 + FMA, when [`Kernel::avx2_fma`] is not
    /// overridden. Implementations mark it `#[inline(always)]`, and keep the
    /// arithmetic out of closures (`Option::map`, an array's `map`): a closure is
    /// compiled without the caller's target features, so its `mul_add` becomes a
    /// C-library `fma` call, an order of magnitude slower (same bits).
    fn portable(self) -> Self::Output;
    /// The kernel written for AVX2 + FMA (intrinsics); defaults to the portable
    /// code, compiled with those features (and with AVX-512 where [`avx512`] says so).
    /// Only called when [`avx2_fma`] is true.
    #[inline(always)]
    fn avx2_fma(self) -> Self::Output
    where
        Self: Sized,
    {
        self.portable()
    }
}

/// Runs `k`'s AVX2 + FMA variant compiled with AVX-512 when [`avx512`] allows it, with
/// AVX2 + FMA alone when [`avx2_fma`] does, its portable build otherwise. The same
/// bits on all three (see the module documentation).
pub(crate) fn dispatch<K: Kernel>(k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512dq,avx512bw")]
        fn with_avx512<K: Kernel>(k: K) -> K::Output {
            k.avx2_fma()
        }
        #[target_feature(enable = "avx2,fma")]
        fn with_features<K: Kernel>(k: K) -> K::Output {
            k.avx2_fma()
        }
        if avx512() {
            // SAFETY: `avx512()` is only true when the CPU has AVX2, FMA and the four
            // AVX-512 subsets enabled here.
            return unsafe { with_avx512(k) };
        }
        if avx2_fma() {
            // SAFETY: `avx2_fma()` is only true when the CPU has AVX2 and FMA.
            return unsafe { with_features(k) };
        }
    }
    k.portable()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs this test binary again, the one test `name` only, with the environment
    /// variable `var` set to 1 and `child` marking the child run (the variables are
    /// read once per process, so a process cannot switch builds; hence the child), and
    /// asserts that the child's test passed.
    fn rerun_as_child(name: &str, var: &str, child: &str) {
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            .args(["--exact", name, "--test-threads", "1"])
            .env(var, "1")
            .env(child, "1")
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && stdout.contains("1 passed"),
            "{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }

    #[test]
    fn the_switch_never_claims_features_the_cpu_lacks() {
        assert!(!avx2_fma() || cpu_has_avx2_fma());
        assert_eq!(avx2_fma(), cpu_has_avx2_fma() && !portable_forced());
        assert!(!avx512() || (cpu_has_avx512() && avx2_fma()));
        assert_eq!(
            avx512(),
            avx2_fma() && cpu_has_avx512() && !avx512_forbidden()
        );
        let expected = match (avx512(), avx2_fma()) {
            (true, _) => "avx512",
            (false, true) => "avx2+fma",
            (false, false) => "portable",
        };
        assert_eq!(build_name(), expected);
    }

    /// Runs this test binary again, this one test only, with `MESHLAP_NO_AVX512=1`: the
    /// child sees the AVX2 + FMA build (or the portable one on a CPU without them) and
    /// the kernels run.
    #[test]
    fn the_environment_variable_keeps_kernels_off_avx512() {
        const CHILD: &str = "MESHLAP_CPU_TEST_AVX512_CHILD";
        if std::env::var_os(CHILD).is_some() {
            assert!(avx512_forbidden());
            assert!(!avx512());
            assert_eq!(avx2_fma(), cpu_has_avx2_fma() && !portable_forced());
            struct Fma(f64, f64, f64);
            impl Kernel for Fma {
                type Output = f64;
                #[inline(always)]
                fn portable(self) -> f64 {
                    self.0.mul_add(self.1, self.2)
                }
            }
            // 0.1·10 + (−1) fused: the exact residual of 0.1's rounding, on any build.
            assert_eq!(dispatch(Fma(0.1, 10.0, -1.0)), 0.1f64.mul_add(10.0, -1.0));
            return;
        }
        rerun_as_child(
            "cpu::tests::the_environment_variable_keeps_kernels_off_avx512",
            NO_AVX512_ENV,
            CHILD,
        );
    }

    /// Runs this test binary again, this one test only, with `MESHLAP_PORTABLE=1`:
    /// the child sees the portable build selected.
    #[test]
    fn the_environment_variable_forces_the_portable_build() {
        const CHILD: &str = "MESHLAP_CPU_TEST_CHILD";
        if std::env::var_os(CHILD).is_some() {
            assert!(portable_forced());
            assert!(!avx2_fma());
            // The kernels run (portable build) and agree with the dispatch.
            struct Add(f64, f64);
            impl Kernel for Add {
                type Output = f64;
                #[inline(always)]
                fn portable(self) -> f64 {
                    self.0 + self.1
                }
            }
            assert_eq!(dispatch(Add(0.5, 0.25)), 0.75);
            return;
        }
        rerun_as_child(
            "cpu::tests::the_environment_variable_forces_the_portable_build",
            PORTABLE_ENV,
            CHILD,
        );
    }
}
