//! The messages: [`Request`]s from the client (the Blender add-on) and [`Reply`]s from the daemon.
//!
//! Wire conventions (see `docs/protocol.md`):
//! - Enums are *externally tagged*: a message is a one-entry map `{"UploadMesh": {..fields..}}`,
//!   and a variant without fields is just its name as a string (`"Stats"`). Chosen over an
//!   internal `"type"` field because serde decodes internally tagged enums through an
//!   intermediate buffer, which would copy every bulk array once more.
//! - Structs are maps keyed by field name (`rmp_serde::to_vec_named`): field order does not
//!   matter and unknown fields are ignored, so a newer peer can add fields.
//! - Variant names are PascalCase, field names snake_case.
//! - Bulk arrays are MessagePack `bin` ([`ByteBuf`]), little-endian, never lists of numbers.
//! - Matrices are 16 f64 in column-major order (Blender's `matrix_world` transposed: element
//!   `4*col + row`).

pub use antumbra_core::alpha::{AlphaOp, Extension, Interpolation};
pub use antumbra_core::settings::NamedSettings;
use serde::{Deserialize, Serialize};
use serde_bytes::ByteBuf;

use crate::compare::{CompareRequest, CompareResultReply};
use crate::limits::Limits;
use crate::trade::{TradeRequest, TradeResultReply};

/// The protocol version this crate speaks; `Hello` must carry it. Version 6: the statistics
/// column `sort_ms` is `prepare_ms` (it holds every per-light preparation, SRDH builds too),
/// and rows gain `trees_refit`. Rows gained `packets`, `steps_per_packet` and
/// `handoffs_per_ray` within version 6 (added columns: a reader skips or defaults them).
/// Version 5: alpha materials
/// (meshes' slots and UV maps, `UploadImage`, `FrameUpdate.alpha_materials`, objects' `materials`).
/// Version 4: `FrameUpdate`
/// carries `instances` (a daemon that skipped the unknown field would drop them unseen).
/// Version 3: no `CameraPath`
/// (an older client would send it and fail mid-session; the version refuses it at `Hello`).
/// Version 2: mesh hashes are XXH3 and render settings a map by name (version 1: FNV-1a,
/// nested settings structs).
pub const PROTOCOL_VERSION: u32 = 6;

/// A message from the client to the daemon.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Request {
    /// First message of a session. Reply: `Welcome`, or `Error { code: VersionMismatch }`.
    Hello {
        version: u32,
        client: String,
        /// The shared secret a daemon listening on TCP requires (its `--token-file`); omitted
        /// (nil) on a Unix socket, where the socket's file mode is the access control.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        token: Option<String>,
    },
    /// Which of these mesh hashes does the daemon lack? Reply: `Missing`.
    MissingMeshes { hashes: Vec<u64> },
    /// Reply: `MeshStored`.
    UploadMesh(UploadMesh),
    /// Which of these alpha image hashes does the daemon lack? Reply: `Missing`.
    MissingImages { hashes: Vec<u64> },
    /// Reply: `ImageStored`.
    UploadImage(UploadImage),
    /// The whole scene state of one frame. Reply: `FrameAccepted`.
    FrameUpdate(FrameUpdate),
    /// Render a frame that was sent with `FrameUpdate`. Replies: zero or more `Progress`, then
    /// `FrameResult` (or `Error`).
    Render(RenderRequest),
    /// Render a frame that was sent with `FrameUpdate` with several methods, compared (see
    /// `docs/protocol.md`). Replies: zero or more `Progress`, then `CompareResult` (or `Error`).
    Compare(CompareRequest),
    /// Sweep a frame that was sent with `FrameUpdate` over the knobs of `antumbra trade` (see
    /// `docs/protocol.md`). Replies: zero or more `Progress`, then `TradeResult` (or `Error`).
    Trade(TradeRequest),
    /// Cancel a running render or comparison. Reply: `Ack`; the render itself ends with
    /// `Error { code: Cancelled }` (or its result, if it finished first).
    Cancel { request_id: u64 },
    /// Daemon statistics. Reply: `DaemonStats`.
    Stats,
    /// End this session (the daemon keeps its mesh cache). Reply: `Ack`, then the daemon closes
    /// the connection.
    Close,
    /// Stop the daemon. Reply: `Ack`.
    Shutdown,
}

/// A message from the daemon to the client.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Reply {
    Welcome {
        version: u32,
        server: String,
        /// Boxed: the largest field of any reply, kept out of every other reply's size.
        limits: Box<Limits>,
    },
    Missing {
        hashes: Vec<u64>,
    },
    MeshStored {
        hash: u64,
        triangles: u32,
    },
    ImageStored {
        hash: u64,
    },
    FrameAccepted {
        frame: i32,
        /// Hashes the frame refers to that the daemon does not hold; upload them before `Render`.
        meshes_missing: Vec<u64>,
        /// Alpha image hashes the frame's materials refer to that the daemon does not hold.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        images_missing: Vec<u64>,
    },
    Ack,
    Progress {
        request_id: u64,
        stage: String,
        done: u32,
        total: u32,
    },
    FrameResult(FrameResultReply),
    CompareResult(CompareResultReply),
    TradeResult(TradeResultReply),
    DaemonStats(DaemonStats),
    Error {
        code: ErrorCode,
        message: String,
        /// False when the daemon will close the connection after this reply.
        session_usable: bool,
        /// The `request_id` of the `Render`, `Compare` or `Trade` this error ends (`Cancelled`, or a failed render);
        /// nil for errors of other requests.
        #[serde(default)]
        request_id: Option<u64>,
    },
}

/// One mesh in object space. `hash` must equal [`antumbra_core::scene::Mesh::content_hash`] of
/// the positions, triangles, normals, material slots and UV maps (the name is not hashed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UploadMesh {
    pub hash: u64,
    pub name: String,
    /// f32 little-endian x, y, z per vertex: 12 bytes a vertex.
    pub positions: ByteBuf,
    /// u32 little-endian vertex indices, 3 per triangle: 12 bytes a triangle.
    pub triangles: ByteBuf,
    /// Optional shading normals at each triangle's corners: f32 little-endian x, y, z, 3 per
    /// triangle (36 bytes a triangle), or empty (left out) for a flat-shaded mesh.
    #[serde(default, skip_serializing_if = "no_bytes")]
    pub normals: ByteBuf,
    /// Optional material slot of each triangle (Blender's `material_index`): u32 little-endian,
    /// 4 bytes a triangle, or empty (every triangle in slot 0).
    #[serde(default, skip_serializing_if = "no_bytes")]
    pub material_slots: ByteBuf,
    /// The UV maps the mesh's alpha materials read; none without alpha.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub uv_maps: Vec<UvMapState>,
}

/// One UV map of a mesh: (u, v) at each triangle's three corners in vertex order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UvMapState {
    /// The name an alpha material's `uv_map` refers to ("" is the active render map).
    pub name: String,
    /// f32 little-endian u, v per corner, 3 corners per triangle: 24 bytes a triangle.
    pub corners: ByteBuf,
}

/// One alpha image. `hash` must equal [`antumbra_core::alpha::AlphaImage::content_hash`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UploadImage {
    pub hash: u64,
    pub width: u32,
    pub height: u32,
    /// f32 little-endian alpha per texel, rows of `width` from the bottom row up (Blender's
    /// order): 4 × width × height bytes.
    pub texels: ByteBuf,
}

fn no_bytes(b: &ByteBuf) -> bool {
    b.is_empty()
}

/// The scene state of one frame; meshes are referred to by hash.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameUpdate {
    pub frame: i32,
    pub objects: Vec<ObjectState>,
    /// Placements of shared meshes as arrays (Blender's instances); their objects follow
    /// `objects`, array by array, in the frame's object order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub instances: Vec<InstanceArrayState>,
    pub camera: CameraState,
    pub lights: Vec<LightState>,
    pub resolution: ResolutionState,
    /// The materials objects' slots refer to by index (`ObjectState::materials`); omitted
    /// for an opaque frame.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub alpha_materials: Vec<AlphaMaterialState>,
}

/// A material whose alpha is not 1 everywhere (mirrors [`antumbra_core::scene::AlphaMaterial`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlphaMaterialState {
    /// Blender's material name, for messages.
    pub name: String,
    /// The UV map an image source reads, by name ("" the active render map).
    #[serde(default)]
    pub uv_map: String,
    pub source: AlphaSourceState,
    /// Math-node operations applied in order: `{"Multiply": c}`, ..., `"OneMinus"`, `"Clamp"`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ops: Vec<AlphaOp>,
}

/// Where a material's alpha starts: a constant, or an image by content hash.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum AlphaSourceState {
    Constant {
        alpha: f32,
    },
    Image {
        /// The hash of an `UploadImage`.
        hash: u64,
        interpolation: Interpolation,
        extension: Extension,
    },
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectState {
    pub name: String,
    pub mesh_hash: u64,
    /// Column-major object-to-world matrix (Blender's `matrix_world`).
    pub world_from_object: [f64; 16],
    pub visible_to_camera: bool,
    pub casts_shadow: bool,
    /// Per material slot, an index into `FrameUpdate::alpha_materials`, or nil for an opaque
    /// slot; omitted when every slot is opaque.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<Option<u32>>,
}

/// Every placement of one mesh with one pair of visibility flags: instance `i` is the object
/// `name[id]` (`ids[i]`, or `i` without ids) at world matrix `i`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InstanceArrayState {
    pub name: String,
    pub mesh_hash: u64,
    /// f32 little-endian world matrices without their last row (0, 0, 0, 1): rows 0, 1 and 2
    /// of four values each, 48 bytes an instance. Blender's matrices are f32, so none is lost.
    /// Empty when `unchanged`.
    #[serde(default, skip_serializing_if = "no_bytes")]
    pub matrices: ByteBuf,
    /// u32 little-endian ids naming the instances (Blender's persistent ids), 4 bytes an
    /// instance, or empty (instances are named by index). Empty when `unchanged`.
    #[serde(default, skip_serializing_if = "no_bytes")]
    pub ids: ByteBuf,
    pub visible_to_camera: bool,
    pub casts_shadow: bool,
    /// The matrices and ids are those of the array of this name in the last frame the session
    /// accepted: only what changed travels.
    #[serde(default, skip_serializing_if = "is_false")]
    pub unchanged: bool,
    /// Every instance's material slots, as [`ObjectState::materials`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<Option<u32>>,
}

/// Mirrors [`antumbra_core::scene::Camera`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraState {
    /// Column-major camera-to-world matrix; the camera looks down its local -Z with +Y up.
    pub world_from_camera: [f64; 16],
    pub lens_mm: f64,
    pub sensor_width_mm: f64,
    pub sensor_height_mm: f64,
    pub sensor_fit: SensorFitState,
    pub shift_x: f64,
    pub shift_y: f64,
    pub clip_start: f64,
    pub clip_end: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum SensorFitState {
    #[default]
    Auto,
    Horizontal,
    Vertical,
}

/// Mirrors [`antumbra_core::scene::Light`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightState {
    pub name: String,
    /// Column-major light-to-world matrix; lights emit along their local -Z.
    pub world_from_light: [f64; 16],
    pub kind: LightKindState,
    pub casts_shadow: bool,
}

/// Mirrors [`antumbra_core::scene::LightKind`]; tagged by a `"type"` field
/// (`{"type": "Sun", "angle": 0.01}`). Read by `light_kind.rs`, whose errors name the kind and
/// the field.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "type")]
pub enum LightKindState {
    Point {
        radius: f64,
    },
    Sun {
        angle: f64,
    },
    Spot {
        radius: f64,
        spot_size: f64,
        spot_blend: f64,
    },
    Area {
        shape: AreaShapeState,
        size_x: f64,
        size_y: f64,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum AreaShapeState {
    Square,
    Rectangle,
    Disk,
    Ellipse,
}

/// Mirrors [`antumbra_core::scene::Resolution`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResolutionState {
    pub x: u32,
    pub y: u32,
    pub percentage: u32,
    pub pixel_aspect_x: f64,
    pub pixel_aspect_y: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderRequest {
    pub frame: i32,
    /// Settings by name (`docs/protocol.md` lists them, `antumbra_core::settings::SCHEMA` defines
    /// them): a missing one takes its default; an unknown name or a wrong type is an error.
    #[serde(default)]
    pub settings: NamedSettings,
    #[serde(default)]
    pub passes: Passes,
    /// Chosen by the client; echoed in `Progress` and `FrameResult`, named by `Cancel`.
    pub request_id: u64,
    /// Render the frame only for the session's state (trees, previous-frame visible set), as
    /// the frame before the first of a farm's chunk: a primary pass, no shadow ray. The
    /// `FrameResult` has no images and no statistics rows (the visible set if asked for).
    /// Omitted when false.
    #[serde(default, skip_serializing_if = "is_false")]
    pub warm_up: bool,
}

/// For `skip_serializing_if`: a flag that is off is left out, so older peers see the messages
/// they know.
pub(crate) fn is_false(flag: &bool) -> bool {
    !*flag
}

/// Which outputs a `FrameResult` carries. Omitted fields take the defaults (all images, no
/// visible set).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Passes {
    /// One shadow mask per shadow-casting light (`shadow.<light>`).
    pub masks: bool,
    /// The mean of the masks (`combined`).
    pub combined: bool,
    /// Traversal work per pixel: `primary.N_B`, `primary.N_L`, `primary.N_T`, `shadow.N_B`, ...
    pub heat_maps: bool,
    /// The triangles a camera ray hit, as (object, primitive) pairs.
    pub visible_set: bool,
    /// Per pixel, the index of the object the primary ray hit in the frame's object list (as
    /// sent in `FrameUpdate`), -1 where it missed: the image `primary.object`, after the heat
    /// maps. Off unless asked for (older peers omit it).
    pub object_ids: bool,
}

impl Default for Passes {
    fn default() -> Self {
        Passes {
            masks: true,
            combined: true,
            heat_maps: true,
            visible_set: false,
            object_ids: false,
        }
    }
}

/// The outputs of one rendered frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameResultReply {
    pub request_id: u64,
    pub frame: i32,
    pub width: u32,
    pub height: u32,
    /// In this order: masks (light order), `combined`, primary heat maps, shadow heat maps;
    /// each only if its pass was requested.
    pub images: Vec<Image>,
    pub stats: Vec<StatsRowState>,
    /// The visible set when requested: u32 LE pairs (object index, triangle index), sorted.
    pub visible: Option<ByteBuf>,
}

/// One single-channel float image, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Image {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// width × height f32 little-endian, row-major from the top-left pixel.
    pub data: ByteBuf,
}

/// A statistics row travels as the core's own row (named MessagePack map, columns documented
/// at [`antumbra_core::stats::StatsRow`]); columns a reader does not know are ignored and
/// columns a writer did not send read as 0.
pub use antumbra_core::stats::StatsRow as StatsRowState;

/// What the daemon has done since it started.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DaemonStats {
    /// Sessions connected now.
    pub sessions: u32,
    /// Sessions since start.
    pub sessions_total: u64,
    pub meshes_cached: u64,
    /// Bytes held by cached meshes (positions, triangles, normals, slots, UV maps) and images.
    pub bytes_cached: u64,
    pub renders_done: u64,
    pub renders_cancelled: u64,
    pub renders_failed: u64,
    pub uptime_s: f64,
    /// Meshes dropped from the cache since start to stay within the memory budget (only meshes
    /// that no connected session uses are dropped).
    pub meshes_evicted: u64,
    /// Alpha images cached (their bytes count in `bytes_cached`, within the same budget).
    pub images_cached: u64,
    /// Alpha images dropped from the cache since start, as meshes are.
    pub images_evicted: u64,
}

impl Request {
    /// The message's type name as it appears on the wire, for logs and error messages.
    pub fn kind(&self) -> &'static str {
        match self {
            Request::Hello { .. } => "Hello",
            Request::MissingMeshes { .. } => "MissingMeshes",
            Request::UploadMesh(_) => "UploadMesh",
            Request::MissingImages { .. } => "MissingImages",
            Request::UploadImage(_) => "UploadImage",
            Request::FrameUpdate(_) => "FrameUpdate",
            Request::Render(_) => "Render",
            Request::Compare(_) => "Compare",
            Request::Trade(_) => "Trade",
            Request::Cancel { .. } => "Cancel",
            Request::Stats => "Stats",
            Request::Close => "Close",
            Request::Shutdown => "Shutdown",
        }
    }
}

impl Reply {
    pub fn kind(&self) -> &'static str {
        match self {
            Reply::Welcome { .. } => "Welcome",
            Reply::Missing { .. } => "Missing",
            Reply::MeshStored { .. } => "MeshStored",
            Reply::ImageStored { .. } => "ImageStored",
            Reply::FrameAccepted { .. } => "FrameAccepted",
            Reply::Ack => "Ack",
            Reply::Progress { .. } => "Progress",
            Reply::FrameResult(_) => "FrameResult",
            Reply::CompareResult(_) => "CompareResult",
            Reply::TradeResult(_) => "TradeResult",
            Reply::DaemonStats(_) => "DaemonStats",
            Reply::Error { .. } => "Error",
        }
    }
}

/// Checks the first message of a session: it must be `Hello` with this crate's
/// [`PROTOCOL_VERSION`]. A mismatch is an error whose reply ends the session.
pub fn check_hello(request: &Request) -> Result<(), crate::ProtocolError> {
    match request {
        Request::Hello { version, .. } if *version == PROTOCOL_VERSION => Ok(()),
        Request::Hello { version, .. } => Err(crate::ProtocolError::VersionMismatch {
            client: *version,
            server: PROTOCOL_VERSION,
        }),
        other => Err(crate::ProtocolError::invalid(
            "session",
            format!("the first message must be Hello, got {}", other.kind()),
        )),
    }
}

/// The reply to a `Hello` that passed [`check_hello`].
pub fn welcome(server: impl Into<String>, limits: &Limits) -> Reply {
    Reply::Welcome {
        version: PROTOCOL_VERSION,
        server: server.into(),
        limits: Box::new(limits.clone()),
    }
}

/// The machine-readable class of an error reply. The human-readable `message` beside it names
/// what was wrong; the code tells a client what to do about it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ErrorCode {
    /// The bytes of a frame were not a valid message (bad MessagePack, unknown message type,
    /// missing field, trailing bytes).
    BadFrame,
    /// The client's protocol version is not the daemon's.
    VersionMismatch,
    /// A frame's length prefix exceeds `Limits::max_frame_bytes`.
    TooLarge,
    /// A well-formed message with values that make no sense (NaN, index out of range, wrong hash,
    /// bad byte length, setting out of range).
    InvalidInput,
    /// A frame refers to a mesh hash the daemon does not hold: upload it and resend the frame.
    UnknownMesh,
    /// A frame's alpha material refers to an image hash the daemon does not hold: upload it.
    UnknownImage,
    /// A count or size above one of the [`crate::Limits`].
    LimitExceeded,
    /// The daemon is doing something else that this request would conflict with.
    Busy,
    /// The render was cancelled by a `Cancel` request.
    Cancelled,
    /// A bug or resource failure in the daemon.
    Internal,
}
