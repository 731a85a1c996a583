//! Value parsers for numeric options with a documented range, so that an out-of-range number
//! is a clap error naming the range instead of an allocation or a run that never ends.

/// A count in `min..=max`; the error names the range, for a negative count or one past
/// `u64` too.
pub fn count(
    min: u64,
    max: u64,
) -> impl Fn(&str) -> Result<usize, String> + Clone + Send + Sync + 'static {
    move |text: &str| {
        let value: i128 = text
            .trim()
            .parse()
            .map_err(|_| format!("{text:?} is not a whole number"))?;
        if (i128::from(min)..=i128::from(max)).contains(&value) {
            usize::try_from(value).map_err(|_| format!("{value} does not fit this machine"))
        } else {
            Err(format!("{value} is not in {min}..={max}"))
        }
    }
}

/// A finite number in `min..=max`; the error names the range and `unit`.
pub fn number(
    min: f64,
    max: f64,
    unit: &'static str,
) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |text: &str| {
        let value: f64 = text
            .trim()
            .parse()
            .map_err(|_| format!("{text:?} is not a number"))?;
        if value.is_finite() && (min..=max).contains(&value) {
            Ok(value)
        } else {
            Err(format!("{} is not in {min}..={max} {unit}", text.trim()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In-range numbers pass, others are errors that name the range.
    #[test]
    fn number_checks_its_range() {
        let secs = number(0.1, 600.0, "s");
        assert_eq!(secs("2.5"), Ok(2.5));
        assert!(secs("1e9").unwrap_err().contains("0.1..=600 s"));
        assert!(secs("NaN").is_err());
        assert!(secs("inf").is_err());
        assert!(secs("ten").unwrap_err().contains("not a number"));
    }

    /// Counts: negative, past `u64` and fractional ones are errors naming the range (or
    /// saying it is no whole number).
    #[test]
    fn count_checks_its_range() {
        let laps = count(1, 50);
        assert_eq!(laps("3"), Ok(3));
        assert!(laps("-1").unwrap_err().contains("1..=50"));
        assert!(laps("0").unwrap_err().contains("1..=50"));
        assert!(laps("18446744073709551616").unwrap_err().contains("1..=50"));
        assert!(laps("2.5").unwrap_err().contains("not a whole number"));
    }
}
