//! Whether the AVX2 halves of the packed path's comparisons can run here.

/// `true` when the CPU has AVX2 and FMA, so a test compares the AVX2 code with the
/// portable code. Without them the test cannot run its AVX2 half: it panics, naming the
/// comparison, unless `VOLGA_ALLOW_NO_AVX2` is set (then it says so on stderr and checks
/// the portable half only), so a missing comparison never passes silently.
#[cfg(target_arch = "x86_64")]
pub(crate) fn avx2_fma(comparison: &str) -> bool {
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        return true;
    }
    assert!(
        std::env::var_os("VOLGA_ALLOW_NO_AVX2").is_some(),
        "{comparison}: this CPU has no AVX2/FMA, so the AVX2 code cannot be compared; \
         set VOLGA_ALLOW_NO_AVX2=1 to check the portable code only"
    );
    eprintln!("note: {comparison}: AVX2 half not run (no AVX2/FMA on this CPU)");
    false
}
