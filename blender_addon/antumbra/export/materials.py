"""Where a material's alpha comes from, as Cycles reads it for shadow rays (issue 38).

``material_alpha(material)`` walks the material's node tree backwards from the Cycles output's
Surface and returns an ``AlphaSource``: opaque, a constant, or an Image Texture's alpha (or
colour, by luminance) read through a UV map, followed by a short list of operations. Its
``contract()`` is the plain dict the Rust core consumes (docs/alpha_export.md):

    {"kind": "opaque"}
    {"kind": "constant", "alpha": a}
    {"kind": "texture", "image": NAME, "channel": "alpha" | "luminance", "uv_map": NAME or "",
     "interpolation": "Linear" | "Closest" | "Cubic" | "Smart",
     "extension": "REPEAT" | "EXTEND" | "CLIP" | "MIRROR",
     "ops": [["MULTIPLY", c], ["GREATER_THAN", c], ["ONE_MINUS"], ["CLAMP"], ...]}

The ops apply in order to the texture's value; the result is clamped to [0, 1]. Alpha here is
opacity: 1 stops a shadow ray, 0 lets it through, between multiplies its transmission by 1 - a
(Cycles' transparent shadows).

Shaders are reduced to their opacity, which is linear in Cycles' closure weights: a Principled
BSDF's is its Alpha, a Transparent BSDF's 1 - luminance(Color), any other shader's 1, and a Mix
Shader's (1 - Fac) * A + Fac * B. A mix stays representable while at most one side (or the Fac)
varies over the surface. Anything else, and every node it cannot evaluate, makes the material
opaque with a warning naming the material and the node; nothing here raises.

Only the node graph is read: pixels are ``alpha_image``'s job, UVs and slots ``alpha_mesh``'s.
EEVEE's blend and shadow modes are recorded (``modes``) but never change the alpha: antumbra
follows Cycles, which ignores them.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

#: The operations the Rust core implements, in the contract's spelling.
OPS = ("MULTIPLY", "ADD", "SUBTRACT", "POWER", "GREATER_THAN", "LESS_THAN", "ONE_MINUS", "CLAMP")

#: Cycles' value for an Image Texture without an image or with a file it cannot load
#: (TEX_IMAGE_MISSING_R, G, B, A: magenta, opaque).
MISSING_TEXTURE = (1.0, 0.0, 1.0, 1.0)

#: Material settings that are EEVEE's only, by Blender version: 3.4's blend and shadow modes,
#: 4.2's render method and transparent-shadow switch (``blend_method`` is 4.2's deprecated alias).
MODE_ATTRIBUTES = (
    "blend_method",
    "shadow_method",
    "surface_render_method",
    "use_transparent_shadow",
)

#: Shader nodes that are opaque to shadow rays whatever their inputs (no transparent closure).
_OPAQUE_SHADERS = {
    "ShaderNodeBsdfDiffuse",
    "ShaderNodeBsdfGlossy",
    "ShaderNodeBsdfAnisotropic",
    "ShaderNodeBsdfGlass",
    "ShaderNodeBsdfRefraction",
    "ShaderNodeBsdfTranslucent",
    "ShaderNodeBsdfSheen",
    "ShaderNodeBsdfVelvet",
    "ShaderNodeBsdfToon",
    "ShaderNodeBsdfHair",
    "ShaderNodeBsdfHairPrincipled",
    "ShaderNodeBsdfMetallic",
    "ShaderNodeSubsurfaceScattering",
    "ShaderNodeEmission",
    "ShaderNodeHoldout",
}


@functools.cache
def luminance_coefficients() -> tuple[float, float, float]:
    """The scene-linear luminance weights Blender converts a colour to a float with (Cycles'
    ``linear_rgb_to_gray``: the film's ``rgb_to_y``, the Y row of the OCIO config's scene-linear
    to XYZ matrix). Read from Blender where it offers the matrix (3.2+); Rec. 709's otherwise."""
    try:
        import mathutils

        convert = mathutils.Color.from_scene_linear_to_xyz_d65
    except (ImportError, AttributeError):
        return (0.2126, 0.7152, 0.0722)
    # The result is a Color holding X, Y, Z: its second component is Y.
    rows = [convert(mathutils.Color(c))[1] for c in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    total = sum(rows)
    # The matrix maps white to D65's Y = 1 up to rounding; normalise so grey stays grey.
    return tuple(v / total for v in rows)


def gray(color) -> float:
    """A constant colour as a float socket reads it (luminance; alpha is dropped)."""
    r, g, b = luminance_coefficients()
    return float(r * color[0] + g * color[1] + b * color[2])


class Unsupported(Exception):
    """A node the walk cannot evaluate; becomes a warning and an opaque material."""

    def __init__(self, node, why: str = "is not supported"):
        super().__init__(why)
        self.node, self.why = node, why


#: Ops that leave every value as it is (Cycles' safe_powf(x, 1) is x, also for x < 0).
_IDENTITIES = {("MULTIPLY", 1.0), ("ADD", 0.0), ("SUBTRACT", 0.0), ("POWER", 1.0)}


@dataclass
class _Expr:
    """A scalar over the surface: a constant, or a texture read followed by ops."""

    const: float | None = None
    texture: dict | None = None
    ops: list = field(default_factory=list)

    @property
    def is_const(self) -> bool:
        return self.texture is None

    def then(self, op: str, *arg: float) -> _Expr:
        if self.is_const:
            return _Expr(const=_apply(self.const, op, *arg))
        if op == "CLAMP" and (self.ops[-1:] == [["CLAMP"]] or self._in_unit_range()):
            return self  # clamping a value already in [0, 1]
        if (op, *arg) in _IDENTITIES:
            return self
        return _Expr(texture=self.texture, ops=[*self.ops, [op, *map(float, arg)]])

    def _in_unit_range(self) -> bool:
        # A byte image's texels are in [0, 1], and so is their linear or cubic (B-spline, a
        # convex combination) interpolation.
        return not self.ops and not self.texture["image_info"]["is_float"]


def _apply(x: float, op: str, *arg: float) -> float:
    """One op on a constant, as Cycles' SVM math evaluates it (so folding agrees with Rust)."""
    if op == "MULTIPLY":
        return x * arg[0]
    if op == "ADD":
        return x + arg[0]
    if op == "SUBTRACT":
        return x - arg[0]
    if op == "POWER":
        # Cycles' safe_powf: a negative base to a non-integer power is 0.
        if x < 0.0 and arg[0] != int(arg[0]):
            return 0.0
        try:
            return float(x ** arg[0])
        except ZeroDivisionError:
            return float("inf")
    if op == "GREATER_THAN":
        return 1.0 if x > arg[0] else 0.0
    if op == "LESS_THAN":
        return 1.0 if x < arg[0] else 0.0
    if op == "ONE_MINUS":
        return 1.0 - x
    if op == "CLAMP":
        return min(max(x, 0.0), 1.0)
    raise ValueError(op)


@dataclass
class AlphaSource:
    """Where one material's alpha comes from (see the module's docstring for ``contract()``)."""

    kind: str = "opaque"
    alpha: float = 1.0
    image: str = ""
    channel: str = "alpha"
    uv_map: str = ""
    interpolation: str = "Linear"
    extension: str = "REPEAT"
    ops: list = field(default_factory=list)
    #: For ``luminance``: whether Cycles divides the colour by alpha (``alpha_image``'s
    #: ``unassociate``: the node's Alpha output is linked too). Not in the contract: it shapes
    #: the image's values, which travel by content.
    unassociate: bool = False
    #: The Image Texture node read (for messages naming the node); "" without one.
    node: str = ""
    #: The image as Blender holds it: size, packed or file, colour space, alpha mode.
    image_info: dict = field(default_factory=dict)
    #: EEVEE's blend/shadow settings as this Blender spells them; informative only.
    modes: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    @property
    def needs_alpha(self) -> bool:
        """Whether triangles of this material need the per-triangle alpha path."""
        return self.kind != "opaque"

    def contract(self) -> dict:
        if self.kind == "opaque":
            return {"kind": "opaque"}
        if self.kind == "constant":
            return {"kind": "constant", "alpha": self.alpha}
        return {
            "kind": "texture",
            "image": self.image,
            "channel": self.channel,
            "uv_map": self.uv_map,
            "interpolation": self.interpolation,
            "extension": self.extension,
            "ops": [list(op) for op in self.ops],
        }


def _describe(node) -> str:
    return f"node '{node.name}' ({node.bl_idname})"


def _linked_from(socket):
    """The output socket feeding an input, through reroutes; None when unlinked (a muted link
    reads as unlinked, as in Blender)."""
    while socket.is_linked:
        link = socket.links[0]
        if getattr(link, "is_muted", False):
            return None
        if not link.is_valid:
            raise Unsupported(link.to_node, "has an invalid link")
        node = link.from_node
        if node.bl_idname != "NodeReroute":
            if node.mute:
                raise Unsupported(node, "is muted")
            return link.from_socket
        socket = node.inputs[0]
    return None


def _default_scalar(socket) -> float:
    value = socket.default_value
    if isinstance(value, float | int):
        return float(value)
    return gray(value)  # a colour or vector default read as a float: luminance


class _Walk:
    def __init__(self, material):
        self.material = material

    # Scalars -----------------------------------------------------------------------------

    def scalar(self, socket) -> _Expr:
        """A float input's value over the surface."""
        source = _linked_from(socket)
        if source is None:
            return _Expr(const=_default_scalar(socket))
        node = source.node
        kind = node.bl_idname
        if kind == "ShaderNodeTexImage":
            return self.texture(node, source)
        if kind == "ShaderNodeMath":
            return self.math(node)
        if kind == "ShaderNodeInvert":
            return self.invert(node)
        if kind == "ShaderNodeValue":
            return _Expr(const=float(source.default_value))
        if kind == "ShaderNodeRGB":
            return _Expr(const=gray(source.default_value))
        raise Unsupported(node, "feeding Alpha is not supported")

    def texture(self, node, output) -> _Expr:
        channel = "alpha" if output.identifier == "Alpha" else "luminance"
        if node.projection != "FLAT":
            raise Unsupported(node, f"has projection {node.projection}; only FLAT is supported")
        image = node.image
        if image is None:
            # Cycles reads the missing-texture colour: opaque magenta.
            value = MISSING_TEXTURE[3] if channel == "alpha" else gray(MISSING_TEXTURE)
            return _Expr(const=value)
        if image.source not in {"FILE", "GENERATED"}:
            raise Unsupported(node, f"reads a {image.source} image; only single images are")
        if channel == "alpha" and image.alpha_mode == "NONE":
            return _Expr(const=1.0)  # Cycles ignores the file's alpha
        uv_map = self.uv_map(node.inputs["Vector"])
        texture = {
            "image": image.name,
            "channel": channel,
            # Cycles divides the colour by alpha only when the Alpha output is used too.
            "unassociate": channel == "luminance" and node.outputs["Alpha"].is_linked,
            "uv_map": uv_map,
            "interpolation": node.interpolation,
            "extension": node.extension,
            "node": node.name,
            "image_info": _image_info(image),
        }
        return _Expr(texture=texture)

    def uv_map(self, vector) -> str:
        """The UV map a texture's Vector reads: "" for the active render map (unlinked, or a
        Texture Coordinate's UV), else the UV Map node's name."""
        source = _linked_from(vector)
        if source is None:
            return ""
        node = source.node
        if node.bl_idname == "ShaderNodeUVMap":
            if node.from_instancer:
                raise Unsupported(node, "reads the instancer's UV map; not supported")
            return node.uv_map
        if node.bl_idname == "ShaderNodeTexCoord" and source.identifier == "UV":
            if node.from_instancer:
                raise Unsupported(node, "reads the instancer's UV map; not supported")
            return ""
        raise Unsupported(node, "as a texture's Vector is not supported (only a UV map)")

    def math(self, node) -> _Expr:
        op = node.operation
        if op not in {"MULTIPLY", "ADD", "SUBTRACT", "POWER", "GREATER_THAN", "LESS_THAN"}:
            raise Unsupported(node, f"with operation {op} is not supported")
        a, b = self.scalar(node.inputs[0]), self.scalar(node.inputs[1])
        if a.is_const and b.is_const:
            out = _Expr(const=_apply(a.const, op, b.const))
        elif not b.is_const and not a.is_const:
            raise Unsupported(node, "combines two textures; not supported")
        elif b.is_const:  # texture OP constant
            out = a.then(op, b.const)
        else:  # constant OP texture
            out = self._constant_first(node, op, a.const, b)
        return out.then("CLAMP") if node.use_clamp else out

    @staticmethod
    def _constant_first(node, op: str, c: float, x: _Expr) -> _Expr:
        if op in {"MULTIPLY", "ADD"}:
            return x.then(op, c)
        if op == "SUBTRACT":  # c - x = (1 - x) + (c - 1)
            out = x.then("ONE_MINUS")
            return out if c == 1.0 else out.then("ADD", c - 1.0)
        if op == "GREATER_THAN":  # c > x  <=>  x < c
            return x.then("LESS_THAN", c)
        if op == "LESS_THAN":
            return x.then("GREATER_THAN", c)
        raise Unsupported(node, f"with operation {op} and the texture second is not supported")

    def invert(self, node) -> _Expr:
        """Invert: mix(x, 1 - x, Fac); luminance commutes with it (the weights sum to 1)."""
        fac = self.scalar(node.inputs["Fac"])
        if not fac.is_const:
            raise Unsupported(node, "with a linked Fac is not supported")
        x = self.scalar(node.inputs["Color"])
        f = fac.const
        if f == 1.0:
            return x.then("ONE_MINUS")
        if f == 0.0:
            return x
        return x.then("MULTIPLY", 1.0 - 2.0 * f).then("ADD", f)

    # Shaders -----------------------------------------------------------------------------

    def opacity(self, socket) -> _Expr:
        """A shader socket's opacity to shadow rays."""
        source = _linked_from(socket)
        if source is None:
            return _Expr(const=1.0)  # an unlinked shader input: Cycles renders it black
        node = source.node
        kind = node.bl_idname
        if kind == "ShaderNodeBsdfPrincipled":
            return self.scalar(node.inputs["Alpha"]).then("CLAMP")
        if kind == "ShaderNodeBsdfTransparent":
            if node.inputs["Color"].is_linked:
                raise Unsupported(node, "with a linked Color is not supported")
            return _Expr(const=min(max(1.0 - gray(node.inputs["Color"].default_value), 0.0), 1.0))
        if kind == "ShaderNodeMixShader":
            return self.mix(node)
        if kind in _OPAQUE_SHADERS:
            return _Expr(const=1.0)
        raise Unsupported(node, "as the surface shader is not supported")

    def mix(self, node) -> _Expr:
        """(1 - Fac) * A + Fac * B, with Fac clamped to [0, 1] as Cycles' mix closure does."""
        fac = self.scalar(node.inputs[0]).then("CLAMP")
        a, b = self.opacity(node.inputs[1]), self.opacity(node.inputs[2])
        if fac.is_const:
            f = fac.const
            if a.is_const and b.is_const:
                return _Expr(const=(1.0 - f) * a.const + f * b.const)
            if f == 0.0:
                return a
            if f == 1.0:
                return b
            if a.is_const == b.is_const:
                raise Unsupported(node, "mixes two textured alphas; not supported")
            varying, other, weight = (b, a.const, f) if a.is_const else (a, b.const, 1.0 - f)
            # weight * varying + (1 - weight) * other
            return varying.then("MULTIPLY", weight).then("ADD", (1.0 - weight) * other)
        if not (a.is_const and b.is_const):
            raise Unsupported(node, "mixes a textured alpha with a textured Fac; not supported")
        # a + Fac * (b - a): the Transparent BSDF first gives Fac, second 1 - Fac.
        if a.const == 0.0 and b.const == 1.0:
            return fac
        if a.const == 1.0 and b.const == 0.0:
            return fac.then("ONE_MINUS")
        return fac.then("MULTIPLY", b.const - a.const).then("ADD", a.const)


def _image_info(image) -> dict:
    packed = image.packed_file is not None or bool(getattr(image, "packed_files", ()))
    return {
        "name": image.name,
        "size": [int(image.size[0]), int(image.size[1])],
        "source": image.source,
        "packed": packed,
        "filepath": image.filepath,
        "colorspace": image.colorspace_settings.name,
        "alpha_mode": image.alpha_mode,
        "is_float": bool(image.is_float),
    }


def material_modes(material) -> dict:
    """EEVEE's settings this Blender has (3.4: blend/shadow method; 4.2+: render method and
    transparent shadows). Cycles, and so antumbra, ignores them."""
    return {name: getattr(material, name) for name in MODE_ATTRIBUTES if hasattr(material, name)}


def _output_node(tree):
    """The Material Output Cycles renders: the active one for Cycles or for all engines."""
    getter = getattr(tree, "get_output_node", None)
    if getter is not None:
        return getter("CYCLES")
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    active = [n for n in outputs if n.is_active_output and n.target in {"ALL", "CYCLES"}]
    return (active or outputs or [None])[0]


def material_alpha(material) -> AlphaSource:
    """Where MATERIAL's alpha comes from (None, an empty slot: opaque). Never raises for a
    graph it cannot read: that material is opaque with a warning naming it and the node."""
    if material is None:
        return AlphaSource()
    modes = material_modes(material)
    tree = material.node_tree
    # 5.0 deprecates use_nodes (always on); before, a material without nodes is Cycles' diffuse.
    if tree is None or not getattr(material, "use_nodes", True):
        return AlphaSource(modes=modes)
    output = _output_node(tree)
    if output is None:
        return AlphaSource(modes=modes)
    try:
        expr = _Walk(material).opacity(output.inputs["Surface"])
    except Unsupported as e:
        warning = f"material '{material.name}': {_describe(e.node)} {e.why}; exported opaque"
        return AlphaSource(modes=modes, warnings=[warning])
    if expr.is_const:
        alpha = min(max(expr.const, 0.0), 1.0)
        if alpha >= 1.0:
            return AlphaSource(modes=modes)
        return AlphaSource(kind="constant", alpha=alpha, modes=modes)
    t = expr.texture
    warnings = []
    info = t["image_info"]
    if t["channel"] == "luminance" and t["interpolation"] != "Closest":
        if not info["is_float"] and info["colorspace"] == "sRGB":
            warnings.append(
                f"material '{material.name}': node '{t['node']}' (ShaderNodeTexImage) reads an "
                f"sRGB image's colour as alpha with {t['interpolation']} interpolation; Cycles "
                "decodes the colour after interpolating it, the export per texel, so alpha "
                "between texels differs (Closest is exact)"
            )
    ops = expr.ops
    while ops and ops[-1] == ["CLAMP"]:
        ops = ops[:-1]  # the contract clamps the result anyway
    return AlphaSource(
        kind="texture",
        image=t["image"],
        channel=t["channel"],
        uv_map=t["uv_map"],
        interpolation=t["interpolation"],
        extension=t["extension"],
        ops=ops,
        node=t["node"],
        unassociate=t["unassociate"],
        image_info=t["image_info"],
        modes=modes,
        warnings=warnings,
    )
