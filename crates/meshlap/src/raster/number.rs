//! Short number labels for axis ticks and legends.

/// `v` with at most `digits` significant digits and no trailing zeros: plain for
/// magnitudes in `[10⁻³, 10⁵)` (`0.0412`, `1500`), otherwise in scientific notation
/// (`1e-4`, `2.5e-7`, `3.2e6`). Zero is `0`; non-finite values print as Rust does.
pub fn compact(v: f64, digits: usize) -> String {
    let digits = digits.max(1);
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let decimals = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.prec$e}", prec = digits - 1);
        match s.split_once('e') {
            Some((m, e)) if m.contains('.') => {
                format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::compact;

    #[test]
    fn plain_and_scientific() {
        assert_eq!(compact(0.0, 3), "0");
        assert_eq!(compact(0.041234, 3), "0.0412");
        assert_eq!(compact(-0.041234, 3), "-0.0412");
        assert_eq!(compact(1500.0, 4), "1500");
        assert_eq!(compact(123.456, 3), "123");
        assert_eq!(compact(0.25, 4), "0.25");
        assert_eq!(compact(200.00000000000003, 4), "200");
        assert_eq!(compact(1e-4, 4), "1e-4");
        assert_eq!(compact(2.5e-7, 3), "2.5e-7");
        assert_eq!(compact(3.2e6, 2), "3.2e6");
        assert_eq!(compact(1.0, 3), "1");
        assert_eq!(compact(f64::INFINITY, 3), "inf");
    }
}
