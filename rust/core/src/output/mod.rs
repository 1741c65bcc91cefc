//! Image output: float planes written as 32-bit float EXR (for numbers) and as PNG (masks in
//! grey, heat maps through a perceptual colour map with their scale). Every file is written
//! atomically, so a reader never sees a half-written image under its final name.

mod colormap;
mod colormap_tables;
mod difference;
mod exr;
mod font;
mod frame_files;
mod heatmap;
mod legend;
mod names;
mod png;

pub use self::colormap::ColorMap;
pub use self::difference::{
    difference_plane, difference_scale, diverging_rgb, write_difference_png,
};
pub use self::exr::{read_exr, write_exr};
pub use self::frame_files::{frame_stem, planes, write_frame_files, FrameFiles, Outputs};
pub use self::heatmap::{heatmap_rgb, write_heatmap_png, HeatLegend, HeatScale};
pub use self::legend::heat_legend_height;
pub use self::names::{file_safe, mask_names, MaskName, MAX_LIGHT_NAME_BYTES};
pub use self::png::write_mask_png;

/// Sorted names of everything in a folder, hidden temporary files included (tests check that
/// a write leaves nothing behind).
#[cfg(test)]
pub(crate) fn file_names(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}
