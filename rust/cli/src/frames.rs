//! Frame ranges and image sizes as typed on the command line.

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

/// "640x360".
pub fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("--size: '{s}' is not WxH"))?;
    let w: u32 = w
        .parse()
        .with_context(|| format!("--size: bad width in '{s}'"))?;
    let h: u32 = h
        .parse()
        .with_context(|| format!("--size: bad height in '{s}'"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        bail!("--size: {w}x{h} is outside 1x1..16384x16384");
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_sizes() {
        assert_eq!(parse_frames("3").unwrap(), 3..=3);
        assert_eq!(parse_frames("1-24").unwrap(), 1..=24);
        assert!(parse_frames("5-2").is_err());
        assert!(parse_frames("a-b").is_err());
        assert_eq!(parse_size("640x360").unwrap(), (640, 360));
        assert!(parse_size("0x10").is_err());
        assert!(parse_size("100000x100000").is_err());
    }
}
