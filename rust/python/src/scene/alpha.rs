//! Alpha materials (the exporter's contract, `docs/alpha_export.md`): constant or texture
//! sources and their Math-node ops.

use antumbra_protocol::{
    AlphaMaterialState, AlphaOp, AlphaSourceState, Extension, Interpolation, Limits,
};
use pyo3::prelude::*;

use super::fields::{choice, integer, items, number, string, Fields};
use super::objects::item_label;
use crate::error::{ClientError, ClientResult};

pub(super) const ALPHA_MATERIAL_FIELDS: &[&str] = &[
    "name",
    "kind",
    "alpha",
    "image",
    "channel",
    "uv_map",
    "interpolation",
    "extension",
    "ops",
];

/// The fields only a texture material has (the exporter's contract, `docs/alpha_export.md`).
pub(super) const TEXTURE_ONLY: &[&str] =
    &["image", "channel", "uv_map", "interpolation", "extension"];

/// One Math node of a material's `ops`: `[NAME, constant]`, or `[NAME]` for ONE_MINUS, CLAMP.
pub(super) fn alpha_op(v: &Bound<'_, PyAny>, field: &str) -> ClientResult<AlphaOp> {
    let parts = items(v, field)?;
    let name = match parts.first() {
        Some(n) => string(n, &format!("{field}[0]"))?,
        None => {
            return Err(ClientError::invalid(format!(
                "{field}: expected [operation, constant] or [operation], got an empty list"
            )))
        }
    };
    #[derive(Clone, Copy)]
    enum Op {
        With(fn(f32) -> AlphaOp),
        Alone(AlphaOp),
    }
    let op = choice(
        &name,
        &format!("{field}[0]"),
        &[
            ("MULTIPLY", Op::With(AlphaOp::Multiply)),
            ("ADD", Op::With(AlphaOp::Add)),
            ("SUBTRACT", Op::With(AlphaOp::Subtract)),
            ("POWER", Op::With(AlphaOp::Power)),
            ("GREATER_THAN", Op::With(AlphaOp::GreaterThan)),
            ("LESS_THAN", Op::With(AlphaOp::LessThan)),
            ("ONE_MINUS", Op::Alone(AlphaOp::OneMinus)),
            ("CLAMP", Op::Alone(AlphaOp::Clamp)),
        ],
    )?;
    match (op, parts.len()) {
        (Op::With(make), 2) => {
            let c = number(&parts[1], &format!("{field}[1]"))? as f32;
            if !c.is_finite() {
                return Err(ClientError::invalid(format!(
                    "{field}[1]: the constant of {name} must be finite, got {c}"
                )));
            }
            Ok(make(c))
        }
        (Op::Alone(op), 1) => Ok(op),
        (Op::With(_), n) => Err(ClientError::invalid(format!(
            "{field}: {name} takes one constant ([{name}, c]), got {} values",
            n - 1
        ))),
        (Op::Alone(_), n) => Err(ClientError::invalid(format!(
            "{field}: {name} takes no constant ([{name}]), got {} values",
            n - 1
        ))),
    }
}

/// `alpha_materials[i]`: the exporter's contract dict with a `name`, its `image` the hash
/// `upload_image` returned. An "opaque" material is a constant alpha of 1.
pub(super) fn alpha_material(
    v: &Bound<'_, PyAny>,
    index: usize,
    limits: &Limits,
) -> ClientResult<AlphaMaterialState> {
    let f = Fields::new(
        v,
        item_label(v, "alpha_materials", index),
        ALPHA_MATERIAL_FIELDS,
    )?;
    let name = f.string("name")?;
    let kind = f.string("kind")?;
    #[derive(Clone, Copy, PartialEq)]
    enum Kind {
        Opaque,
        Constant,
        Texture,
    }
    let kind = choice(
        &kind,
        &f.field("kind"),
        &[
            ("opaque", Kind::Opaque),
            ("constant", Kind::Constant),
            ("texture", Kind::Texture),
        ],
    )?;
    // A field of another kind is a mistake in the caller's contract, not something to ignore.
    let misplaced = |key: &str| -> ClientResult<()> {
        let belongs = match key {
            "alpha" => kind == Kind::Constant,
            k if TEXTURE_ONLY.contains(&k) => kind == Kind::Texture,
            _ => true,
        };
        if !belongs && f.get(key)?.is_some() {
            return Err(ClientError::invalid(format!(
                "{}: not a field of a material of kind '{}'",
                f.field(key),
                f.string("kind")?
            )));
        }
        Ok(())
    };
    for key in ALPHA_MATERIAL_FIELDS {
        misplaced(key)?;
    }
    let source = match kind {
        Kind::Opaque => AlphaSourceState::Constant { alpha: 1.0 },
        Kind::Constant => {
            let field = f.field("alpha");
            let alpha = number(&f.required("alpha")?, &field)? as f32;
            if !alpha.is_finite() {
                return Err(ClientError::invalid(format!(
                    "{field}: must be finite, got {alpha}"
                )));
            }
            AlphaSourceState::Constant { alpha }
        }
        Kind::Texture => {
            let hash = integer::<u64>(
                &f.required("image")?,
                &f.field("image"),
                "an image hash (upload_image's) is an unsigned 64-bit integer",
            )?;
            // The texels already hold the channel the material reads (the exporter's array).
            let channel = f.string_or("channel", "alpha")?;
            choice(
                &channel,
                &f.field("channel"),
                &[("alpha", ()), ("luminance", ())],
            )?;
            let interpolation = choice(
                &f.string_or("interpolation", "Linear")?,
                &f.field("interpolation"),
                &[
                    ("Linear", Interpolation::Linear),
                    ("Closest", Interpolation::Closest),
                    ("Cubic", Interpolation::Cubic),
                    // Cycles renders Smart as Cubic.
                    ("Smart", Interpolation::Cubic),
                ],
            )?;
            let extension = choice(
                &f.string_or("extension", "REPEAT")?,
                &f.field("extension"),
                &[
                    ("REPEAT", Extension::Repeat),
                    ("EXTEND", Extension::Extend),
                    ("CLIP", Extension::Clip),
                    ("MIRROR", Extension::Mirror),
                ],
            )?;
            AlphaSourceState::Image {
                hash,
                interpolation,
                extension,
            }
        }
    };
    let ops = match f.get("ops")? {
        None => Vec::new(),
        Some(v) => {
            let field = f.field("ops");
            let list = items(&v, &field)?;
            if list.len() as u64 > limits.max_alpha_ops {
                return Err(ClientError::invalid(format!(
                    "{field}: {} operations exceed the limit of {} (max_alpha_ops)",
                    list.len(),
                    limits.max_alpha_ops
                )));
            }
            list.iter()
                .enumerate()
                .map(|(i, op)| alpha_op(op, &format!("{field}[{i}]")))
                .collect::<ClientResult<Vec<_>>>()?
        }
    };
    Ok(AlphaMaterialState {
        name,
        uv_map: f.string_or("uv_map", "")?,
        source,
        ops,
    })
}
