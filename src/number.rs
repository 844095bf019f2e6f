//! Numbers for people to read: what `texel inspect`, the survey and the readers' errors print
//! of values read from files, which may be anything a float holds.

/// A number from a file, for a person: fixed-point where that reads well, else in
/// scientific notation. A damaged or hostile file's 1e300 shows as `1.0000e300`, not as 301
/// digits, and a cell of 1e-30 m as `1.0000e-30`, not as `0.0000`. The width and alignment it
/// is written with apply (`{:>11}`); give the places here, not as a precision there.
pub struct Number {
    value: f64,
    /// Places after the point; `None`: as few as tell the value exactly.
    decimals: Option<usize>,
}

/// [`Number`]: `value` with `decimals` places.
pub fn number(value: impl Into<f64>, decimals: usize) -> Number {
    Number {
        value: value.into(),
        decimals: Some(decimals),
    }
}

/// [`Number`]: `value` in as few digits as tell it exactly (a value a user gave, shown as
/// given: `120`, `0.25`, `1e300`). An f64 only: an f32 widened to f64 would show its binary
/// tail (0.1f32 as 0.10000000149011612).
pub fn shortest(value: f64) -> Number {
    Number {
        value,
        decimals: None,
    }
}

impl std::fmt::Display for Number {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.value;
        // Below this a value would show as zero (or as a run of zeros); from 1e9 up, as a run
        // of digits.
        let smallest = match self.decimals {
            Some(d) => 0.5 * 10f64.powi(-(d.min(300) as i32)),
            None => 1e-4,
        };
        let fixed = !x.is_finite() || x == 0.0 || (smallest..1e9).contains(&x.abs());
        let text = match (self.decimals, fixed) {
            (Some(d), true) => format!("{x:.d$}"),
            (Some(d), false) => format!("{x:.d$e}"),
            (None, true) => format!("{x}"),
            (None, false) => format!("{x:e}"),
        };
        f.pad(&text)
    }
}

#[cfg(test)]
mod tests {
    use super::{number, shortest};

    #[test]
    fn numbers_read_as_numbers_at_any_size() {
        assert_eq!(number(0.03125, 4).to_string(), "0.0312");
        assert_eq!(number(-12.5f32, 1).to_string(), "-12.5");
        assert_eq!(number(0.0, 3).to_string(), "0.000");
        assert_eq!(number(999_999_999.0, 1).to_string(), "999999999.0");
        assert_eq!(number(1e300, 4).to_string(), "1.0000e300");
        assert_eq!(number(-3.4e38f32, 2).to_string(), "-3.40e38");
        assert_eq!(number(1e-30, 4).to_string(), "1.0000e-30");
        assert_eq!(number(f64::MIN_POSITIVE / 4.0, 2).to_string(), "5.56e-309");
        assert_eq!(number(f64::INFINITY, 2).to_string(), "inf");
        assert_eq!(number(f64::NAN, 2).to_string(), "NaN");
        assert_eq!(format!("[{:>9}]", number(2.5, 2)), "[     2.50]");
        assert_eq!(format!("[{:<9}]", number(1e20, 1)), "[1.0e20   ]");
        assert_eq!(shortest(120.0).to_string(), "120");
        assert_eq!(shortest(0.25).to_string(), "0.25");
        assert_eq!(shortest(1e300).to_string(), "1e300");
        assert_eq!(shortest(-1.5e-7).to_string(), "-1.5e-7");
    }
}
