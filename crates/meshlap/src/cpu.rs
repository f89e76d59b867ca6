//! The one place that decides whether meshlap's own SIMD kernels run their AVX2 + FMA
//! build or the portable one.
//!
//! Three kernels are compiled twice, once with `#[target_feature(enable =
//! "avx2,fma")]` and once for the baseline x86-64 target (SSE2): the thin products of
//! the Krylov–Schur eigensolver (`spectral::thin_products`), the codec's dense
//! eigensolver (`spectral::dense_evd`, bit-identical on both builds; in its AVX2
//! build the inverse iteration's and the QL iteration's row steps are intrinsics,
//! the same IEEE operations per lane as the portable steps) and the
//! shift-invert solves of the partial eigensolver (`spectral::partial::solve`).
//! [`avx2_fma`] says which build runs: the CPU's features, detected once, unless the
//! environment variable **`MESHLAP_PORTABLE`** is set to anything but `0` or the empty
//! string when the process first asks (read once and cached), which forces the
//! portable build everywhere — so that tests, and a user who suspects a SIMD path, can
//! run the code a CPU without AVX2/FMA runs. faer's own kernels (through `pulp`) pick
//! their instruction set by themselves and are not affected; the `.mlz` codec does
//! not use them for anything it decodes (see `codec::spectral`).

use std::sync::OnceLock;

/// Name of the environment variable that forces the portable kernels.
pub const PORTABLE_ENV: &str = "MESHLAP_PORTABLE";

/// Whether `MESHLAP_PORTABLE` asks for the portable kernels (read once per process).
pub fn portable_forced() -> bool {
    static FORCED: OnceLock<bool> = OnceLock::new();
    *FORCED
        .get_or_init(|| std::env::var_os(PORTABLE_ENV).is_some_and(|v| !v.is_empty() && v != "0"))
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

/// Whether meshlap's kernels run their AVX2 + FMA build: the CPU has both features and
/// `MESHLAP_PORTABLE` is not set. Callers may only enter a function compiled with
/// `#[target_feature(enable = "avx2,fma")]` when this is true.
pub fn avx2_fma() -> bool {
    cpu_has_avx2_fma() && !portable_forced()
}

/// A kernel with an AVX2 + FMA build and a portable one (see [`dispatch`]).
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
    /// code, compiled with those features. Only called when [`avx2_fma`] is true.
    #[inline(always)]
    fn avx2_fma(self) -> Self::Output
    where
        Self: Sized,
    {
        self.portable()
    }
}

/// Runs `k`'s AVX2 + FMA build when [`avx2_fma`] allows it, its portable build
/// otherwise.
pub(crate) fn dispatch<K: Kernel>(k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx2,fma")]
        fn with_features<K: Kernel>(k: K) -> K::Output {
            k.avx2_fma()
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

    #[test]
    fn the_switch_never_claims_features_the_cpu_lacks() {
        assert!(!avx2_fma() || cpu_has_avx2_fma());
        assert_eq!(avx2_fma(), cpu_has_avx2_fma() && !portable_forced());
    }

    /// Runs this test binary again, this one test only, with `MESHLAP_PORTABLE=1`:
    /// the child sees the portable build selected (the variable is read once, so a
    /// process cannot switch; hence the child).
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
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            .args([
                "--exact",
                "cpu::tests::the_environment_variable_forces_the_portable_build",
                "--test-threads",
                "1",
            ])
            .env(PORTABLE_ENV, "1")
            .env(CHILD, "1")
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && stdout.contains("1 passed"),
            "{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
