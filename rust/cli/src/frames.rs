//! Frame ranges as typed on the command line (image sizes are `antumbra_core::scene::ImageSize`).

use anyhow::{bail, Context, Result};
use std::ops::RangeInclusive;

/// "7" or "1-24".
pub fn parse_frames(s: &str) -> Result<RangeInclusive<i32>> {
    let (a, b) = match s.split_once('-') {
        Some((a, b)) if !a.is_empty() => (a, b),
        _ => (s, s),
    };
    let a: i32 = a
        .trim()
        .parse()
        .with_context(|| format!("--frames: '{s}' is not A-B"))?;
    let b: i32 = b
        .trim()
        .parse()
        .with_context(|| format!("--frames: '{s}' is not A-B"))?;
    if b < a {
        bail!("--frames: the range {a}-{b} is empty");
    }
    Ok(a..=b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges() {
        assert_eq!(parse_frames("3").unwrap(), 3..=3);
        assert_eq!(parse_frames("1-24").unwrap(), 1..=24);
        assert!(parse_frames("5-2").is_err());
        assert!(parse_frames("a-b").is_err());
    }
}
