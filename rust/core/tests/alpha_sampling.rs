//! Alpha images sampled as Cycles' CPU kernel samples them (texel-exact cases at borders,
//! u = 1, negative and huge coordinates), alpha programs evaluated in order, and bad input
//! rejected with errors that name the field.

use antumbra_core::alpha::{
    AlphaImage, AlphaOp, AlphaProgram, AlphaScene, AlphaTriangles, Extension, FlaggedTriangle,
    Interpolation,
};
use antumbra_core::Error;

use Extension::*;
use Interpolation::*;

/// 4x2: bottom row 1, 2, 3, 4; top row 5, 6, 7, 8 (as alphas these are out of [0, 1], which
/// sampling does not care about and which makes every texel tell).
fn img() -> AlphaImage {
    AlphaImage {
        width: 4,
        height: 2,
        texels: (1..=8).map(|i| i as f32).collect(),
    }
}

fn closest(ext: Extension, u: f32, v: f32) -> f32 {
    img().sample(Closest, ext, u, v)
}

fn linear(ext: Extension, u: f32, v: f32) -> f32 {
    img().sample(Linear, ext, u, v)
}

#[test]
fn closest_reads_the_texel_containing_the_point() {
    for ext in [Repeat, Extend, Clip, Mirror] {
        assert_eq!(closest(ext, 0.1, 0.1), 1.0, "{ext:?}");
        assert_eq!(closest(ext, 0.3, 0.1), 2.0, "{ext:?}");
        assert_eq!(closest(ext, 0.99, 0.9), 8.0, "{ext:?}");
        // Texel edges belong to the texel above: u = 0.25 is x = 1.0.
        assert_eq!(closest(ext, 0.25, 0.5), 6.0, "{ext:?}");
    }
}

#[test]
fn closest_at_and_past_the_borders() {
    // u = 1 is x = 4: wrapped to column 0, clamped to 3, outside for clip, mirrored to 3.
    assert_eq!(closest(Repeat, 1.0, 0.1), 1.0);
    assert_eq!(closest(Extend, 1.0, 0.1), 4.0);
    assert_eq!(closest(Clip, 1.0, 0.1), 0.0);
    assert_eq!(closest(Mirror, 1.0, 0.1), 4.0);
    // Negative: x = -0.4 is column -1.
    assert_eq!(closest(Repeat, -0.1, 0.1), 4.0);
    assert_eq!(closest(Extend, -0.1, 0.1), 1.0);
    assert_eq!(closest(Clip, -0.1, 0.1), 0.0);
    assert_eq!(closest(Mirror, -0.1, 0.1), 1.0);
    // Cycles' frac takes a negative integer one lower: x = -4 is column -5, so Repeat reads
    // column 3 and Mirror column 4 - 1 = 3.
    assert_eq!(closest(Repeat, -1.0, 0.1), 4.0);
    assert_eq!(closest(Mirror, -1.0, 0.1), 4.0);
    // Past one period: x = 4.4 and 5.2.
    assert_eq!(closest(Repeat, 1.1, 0.1), 1.0);
    assert_eq!(closest(Mirror, 1.1, 0.1), 4.0);
    assert_eq!(closest(Mirror, 1.3, 0.1), 3.0);
    // Huge: x = 4e7 (column 0 of a period) and -4e7 (column 3, as -1 above).
    assert_eq!(closest(Repeat, 1e7, 0.1), 1.0);
    assert_eq!(closest(Repeat, -1e7, 0.1), 4.0);
    assert_eq!(closest(Extend, 1e7, -1e7), 4.0);
    assert_eq!(closest(Clip, 1e7, 0.1), 0.0);
    assert_eq!(closest(Mirror, 1e7, 0.1), 1.0);
    // v too: v = 1 wraps to row 0, v = -0.1 is row -1.
    assert_eq!(closest(Repeat, 0.1, 1.0), 1.0);
    assert_eq!(closest(Repeat, 0.1, -0.1), 5.0);
    assert_eq!(closest(Extend, 0.1, 1.5), 5.0);
}

#[test]
fn linear_blends_the_four_nearest_texel_centres() {
    // At a texel centre (x - 0.5 integer) the texel itself, bit for bit.
    for ext in [Repeat, Extend, Clip, Mirror] {
        assert_eq!(linear(ext, 0.375, 0.25), 2.0, "{ext:?}");
        assert_eq!(linear(ext, 0.625, 0.75), 7.0, "{ext:?}");
        // Half way between columns 1 and 2 of the bottom row.
        assert_eq!(linear(ext, 0.5, 0.25), 2.5, "{ext:?}");
        // Half way between the rows of column 0.
        assert_eq!(linear(ext, 0.125, 0.5), 3.0, "{ext:?}");
    }
    // u = 0, bottom row centre: half column -1, half column 0.
    assert_eq!(linear(Repeat, 0.0, 0.25), 0.5 * 4.0 + 0.5 * 1.0);
    assert_eq!(linear(Extend, 0.0, 0.25), 1.0);
    assert_eq!(linear(Clip, 0.0, 0.25), 0.5);
    assert_eq!(linear(Mirror, 0.0, 0.25), 1.0);
    // u = 1: half column 3, half column 4.
    assert_eq!(linear(Repeat, 1.0, 0.25), 2.5);
    assert_eq!(linear(Extend, 1.0, 0.25), 4.0);
    assert_eq!(linear(Clip, 1.0, 0.25), 2.0);
    // Clip: nothing once a whole texel outside (x - 0.5 below -1).
    assert_eq!(linear(Clip, -0.3, 0.25), 0.0);
    assert_eq!(linear(Clip, 1.2, 0.25), 0.0);
    // The corner between four texels.
    assert_eq!(linear(Repeat, 0.25, 0.5), 0.25 * (1.0 + 2.0 + 5.0 + 6.0));
    // Huge coordinates stay on the image; at x = 4e7 the -0.5 offset rounds away in f32 (as
    // in Cycles' float operations), so the sample is column 0's centre exactly.
    assert_eq!(linear(Repeat, 1e7, 0.25), 1.0);
    assert_eq!(linear(Extend, -1e7, 0.25), 1.0);
}

#[test]
fn cubic_is_cycles_b_spline() {
    let flat = AlphaImage {
        width: 3,
        height: 3,
        texels: vec![0.75; 9],
    };
    for ext in [Repeat, Extend, Mirror] {
        let a = flat.sample(Cubic, ext, 0.4, 0.7);
        assert!((a - 0.75).abs() < 1e-6, "{ext:?}: {a}");
    }
    // At a texel centre of a row: 1/6, 2/3, 1/6 of the neighbours (Extend, inside).
    let a = img().sample(Cubic, Extend, 0.375, 0.25);
    let row0 = 1.0 / 6.0 * 1.0 + 2.0 / 3.0 * 2.0 + 1.0 / 6.0 * 3.0;
    let row1 = 1.0 / 6.0 * 5.0 + 2.0 / 3.0 * 6.0 + 1.0 / 6.0 * 7.0;
    let want = 5.0 / 6.0 * row0 + 1.0 / 6.0 * row1;
    assert!((a - want).abs() < 1e-5, "{a} vs {want}");
    // Clip: the texels outside read 0, and nothing at all two texels out.
    let edge = img().sample(Cubic, Clip, 0.125, 0.25);
    assert!(edge < img().sample(Cubic, Extend, 0.125, 0.25));
    assert_eq!(img().sample(Cubic, Clip, -0.7, 0.25), 0.0);
}

#[test]
fn programs_apply_their_ops_in_order_and_clamp() {
    let p = |c: f32, ops: Vec<AlphaOp>| AlphaProgram {
        ops,
        ..AlphaProgram::constant(c)
    };
    use AlphaOp::*;
    let eval = |p: AlphaProgram| p.eval(&[], [0.0, 0.0]);
    assert_eq!(
        eval(p(0.25, vec![Multiply(2.0), Add(0.25), OneMinus])),
        0.25
    );
    assert_eq!(eval(p(0.25, vec![OneMinus, Multiply(2.0)])), 1.0);
    assert_eq!(eval(p(0.5, vec![Power(2.0)])), 0.25);
    assert_eq!(eval(p(-0.5, vec![Add(0.5)])), 0.0);
    // safe_powf: a negative base to a non-integer power is 0, to an integer power is powf.
    assert_eq!(eval(p(-0.5, vec![Power(0.5), Add(0.5)])), 0.5);
    assert_eq!(eval(p(-0.5, vec![Power(2.0)])), 0.25);
    assert_eq!(eval(p(0.6, vec![GreaterThan(0.5)])), 1.0);
    assert_eq!(eval(p(0.5, vec![GreaterThan(0.5)])), 0.0);
    assert_eq!(eval(p(0.4, vec![LessThan(0.5)])), 1.0);
    // Clamp mid-program, and the final clamp.
    assert_eq!(eval(p(3.0, vec![Clamp, Subtract(0.5)])), 0.5);
    assert_eq!(eval(p(3.0, vec![Subtract(0.5)])), 1.0);
    // NaN (0 to a negative power, times 0) counts as opaque.
    assert_eq!(eval(p(0.0, vec![Power(-1.0), Multiply(0.0)])), 1.0);
    // An image source reads the image.
    let q = AlphaProgram::image(0, 0, Closest, Repeat);
    assert_eq!(q.eval(&[img()], [0.3, 0.1]), 1.0);
    let mut r = q.clone();
    r.ops = vec![Multiply(0.1)];
    assert_eq!(r.eval(&[img()], [0.3, 0.1]), 2.0 * 0.1);
}

fn flagged(triangle: u32, material: u32, uv: [f32; 2]) -> FlaggedTriangle {
    FlaggedTriangle {
        triangle,
        material,
        uvs: vec![[uv, [1.0, 0.0], [0.0, 1.0]]],
    }
}

fn field(e: Error) -> String {
    match e {
        Error::Invalid { field, .. } => field,
        Error::NonFinite { owner, what, .. } => format!("{owner}: {what}"),
        other => panic!("unexpected error {other}"),
    }
}

#[test]
fn bad_input_errors_name_the_field() {
    let tris = || AlphaTriangles::new(10, 1, vec![flagged(3, 0, [0.0, 0.0])]).unwrap();
    let ok = |images: Vec<AlphaImage>, programs: Vec<AlphaProgram>| {
        AlphaScene::new(images, programs, tris())
    };
    let program = AlphaProgram::image(0, 0, Linear, Repeat);
    ok(vec![img()], vec![program.clone()]).unwrap();

    let empty = AlphaImage {
        width: 0,
        height: 4,
        texels: vec![],
    };
    let e = ok(vec![img(), empty], vec![program.clone()]).unwrap_err();
    assert_eq!(field(e.clone()), "alpha.images[1].size");
    assert!(e.to_string().contains("0 pixels"), "{e}");

    let short = AlphaImage {
        texels: vec![0.5; 7],
        ..img()
    };
    let e = ok(vec![short], vec![program.clone()]).unwrap_err();
    assert_eq!(field(e.clone()), "alpha.images[0].texels");
    assert!(e.to_string().contains("7 texels"), "{e}");

    let mut nan = img();
    nan.texels[5] = f32::NAN;
    let e = ok(vec![nan], vec![program.clone()]).unwrap_err();
    assert_eq!(field(e), "alpha.images[0]: texels");

    let e = ok(vec![img()], vec![AlphaProgram::image(1, 0, Linear, Repeat)]).unwrap_err();
    assert_eq!(field(e), "alpha.materials[0].source.image");
    let e = ok(vec![img()], vec![AlphaProgram::image(0, 1, Linear, Repeat)]).unwrap_err();
    assert_eq!(field(e), "alpha.materials[0].source.uv_set");
    let mut bad_op = program.clone();
    bad_op.ops = vec![AlphaOp::Add(0.0), AlphaOp::Multiply(f32::INFINITY)];
    let e = ok(vec![img()], vec![bad_op]).unwrap_err();
    assert_eq!(field(e), "alpha.materials[0].ops[1]");

    // A flagged triangle whose material does not exist, named by its triangle id.
    let e = AlphaScene::new(
        vec![img()],
        vec![program.clone()],
        AlphaTriangles::new(
            10,
            1,
            vec![flagged(2, 0, [0.0; 2]), flagged(7, 1, [0.0; 2])],
        )
        .unwrap(),
    )
    .unwrap_err();
    assert_eq!(field(e), "alpha.triangles[7].material");

    // Non-finite UVs, named by triangle.
    for bad in [f32::NAN, f32::INFINITY] {
        let e = AlphaTriangles::new(10, 1, vec![flagged(6, 0, [0.5, bad])]).unwrap_err();
        assert_eq!(field(e.clone()), "alpha triangle 6: corner UVs");
        assert!(e.to_string().contains("index 1"), "{e}");
    }
    let e = AlphaTriangles::new(10, 1, vec![flagged(10, 0, [0.0; 2])]).unwrap_err();
    assert_eq!(field(e), "alpha.triangles[10]");
    let e = AlphaTriangles::new(10, 2, vec![flagged(4, 0, [0.0; 2])]).unwrap_err();
    assert_eq!(field(e), "alpha.triangles[4].uvs");
    let twice = vec![flagged(4, 0, [0.0; 2]), flagged(4, 0, [0.0; 2])];
    let e = AlphaTriangles::new(10, 1, twice).unwrap_err();
    assert_eq!(field(e), "alpha.triangles[4]");
}

/// Unflagged triangles carry no per-triangle data: a bit and a share of a rank word.
#[test]
fn unflagged_triangles_cost_bits_only() {
    let n = 1_000_000;
    let none = AlphaTriangles::new(n, 1, vec![]).unwrap();
    assert!(
        none.bytes() <= (n as usize).div_ceil(64) * 12,
        "{}",
        none.bytes()
    );
    let some = AlphaTriangles::new(
        n,
        1,
        vec![flagged(999_999, 0, [0.0; 2]), flagged(64, 0, [0.0; 2])],
    )
    .unwrap();
    assert_eq!(some.rank(64), Some(0));
    assert_eq!(some.rank(999_999), Some(1));
    assert_eq!(some.rank(65), None);
    assert_eq!(some.rank(0), None);
    assert_eq!(some.rank(n), None);
}
