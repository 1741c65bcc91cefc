//! An image size in pixels as it is typed, `WxH` (`640x360`): the command line's `--size`, the
//! visibility prepass and the SRDH ray prepass all read and write it here.

use std::fmt;
use std::str::FromStr;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageSize {
    pub width: u32,
    pub height: u32,
}

/// Why a text is not a size, or a size is out of range; the caller names the field.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ImageSizeError {
    /// No `x` between the two numbers.
    NotWxH(String),
    BadWidth(String),
    BadHeight(String),
    /// A side is 0 or above the largest the field allows.
    Outside {
        size: ImageSize,
        max: u32,
    },
}

impl ImageSize {
    /// The largest side of a rendered image.
    pub const MAX_SIDE: u32 = 16384;
    /// The largest side of a prepass (visibility or SRDH rays): a sample of the frame's rays.
    pub const MAX_PREPASS_SIDE: u32 = 4096;

    pub const fn new(width: u32, height: u32) -> Self {
        ImageSize { width, height }
    }

    /// The size if both sides are in `1..=max`.
    pub fn check(self, max: u32) -> Result<Self, ImageSizeError> {
        let side = |v: u32| (1..=max).contains(&v);
        if side(self.width) && side(self.height) {
            Ok(self)
        } else {
            Err(ImageSizeError::Outside { size: self, max })
        }
    }

    /// `WxH` as an image size: parsed, then both sides in `1..=MAX_SIDE`.
    pub fn parse_image(text: &str) -> Result<Self, ImageSizeError> {
        text.parse::<ImageSize>()?.check(Self::MAX_SIDE)
    }

    pub fn pixels(self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// `WxH` (or `WXH`), two unsigned integers; the range is checked apart ([`ImageSize::check`]).
impl FromStr for ImageSize {
    type Err = ImageSizeError;
    fn from_str(s: &str) -> Result<Self, ImageSizeError> {
        let (w, h) = s
            .split_once(['x', 'X'])
            .ok_or_else(|| ImageSizeError::NotWxH(s.to_string()))?;
        Ok(ImageSize {
            width: w
                .parse()
                .map_err(|_| ImageSizeError::BadWidth(s.to_string()))?,
            height: h
                .parse()
                .map_err(|_| ImageSizeError::BadHeight(s.to_string()))?,
        })
    }
}

impl fmt::Display for ImageSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

impl fmt::Display for ImageSizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImageSizeError::NotWxH(s) => write!(f, "'{s}' is not WxH"),
            ImageSizeError::BadWidth(s) => write!(f, "bad width in '{s}'"),
            ImageSizeError::BadHeight(s) => write!(f, "bad height in '{s}'"),
            ImageSizeError::Outside { size, max } => {
                write!(f, "{size} is outside 1x1..{max}x{max}")
            }
        }
    }
}

impl std::error::Error for ImageSizeError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_writes_wxh() {
        assert_eq!("640x360".parse(), Ok(ImageSize::new(640, 360)));
        assert_eq!("64X32".parse(), Ok(ImageSize::new(64, 32)));
        assert_eq!(ImageSize::new(640, 360).to_string(), "640x360");
        assert!(matches!(
            "640".parse::<ImageSize>(),
            Err(ImageSizeError::NotWxH(_))
        ));
        assert!(matches!(
            "ax3".parse::<ImageSize>(),
            Err(ImageSizeError::BadWidth(_))
        ));
        assert!(matches!(
            "3x-1".parse::<ImageSize>(),
            Err(ImageSizeError::BadHeight(_))
        ));
    }

    #[test]
    fn sides_are_checked_against_the_fields_limit() {
        assert!(ImageSize::parse_image("0x10").is_err());
        assert!(ImageSize::parse_image("100000x100000").is_err());
        assert_eq!(
            ImageSize::parse_image("16384x1"),
            Ok(ImageSize::new(16384, 1))
        );
        let e = ImageSize::new(5000, 8)
            .check(ImageSize::MAX_PREPASS_SIDE)
            .unwrap_err();
        assert_eq!(e.to_string(), "5000x8 is outside 1x1..4096x4096");
    }
}
