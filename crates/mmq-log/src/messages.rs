//! The messages of an mmq log: Foxglove's well-known geometry messages (field for field
//! as in Foxglove's JSON schemas) and mmq's own learning events, with the JSON schema
//! text of each.
//!
//! JSON conventions of the Foxglove schemas: timestamps are `{sec, nsec}`, enums are
//! integers, bytes are base64 strings, and every field the schema requires is present
//! (empty arrays included).

use serde::{Deserialize, Serialize};

/// Schema name, JSON schema text and topic of every channel an mmq log can have.
pub mod topics {
    /// Robot pose as a transform (parent "world", child "robot").
    pub const TF: &str = "/tf";
    /// Robot pose in the world frame.
    pub const POSE: &str = "/robot/pose";
    /// Arena geometry: walls, blocked cells, goal and respawn.
    pub const ARENA: &str = "/viz/arena";
    /// Robot body and heading arrow, in the "robot" frame.
    pub const ROBOT: &str = "/viz/robot";
    /// One message per decision step.
    pub const DECISION: &str = "/rl/decision";
    /// One message per non-zero reward emitted.
    pub const EMITTED: &str = "/rl/reward/emitted";
    /// One message per step at which a reward was delivered.
    pub const DELIVERED: &str = "/rl/reward/delivered";
    /// One message per teleport (action in the goal).
    pub const TELEPORT: &str = "/rl/teleport";
    /// Robot–wall contacts starting and stopping.
    pub const CONTACT: &str = "/sim/contact";
    /// Learner visit counts per cell.
    pub const VISITS: &str = "/rl/heatmap/visits";
    /// Learner greedy values per cell.
    pub const VALUE: &str = "/rl/heatmap/value";
    /// Human-readable run notes.
    pub const LOG: &str = "/foxglove/log";
    /// The robot's own pose estimate in the world frame (robots that control on an
    /// estimate; `/tf` then also carries it, as the frame "robot_estimate").
    pub const POSE_ESTIMATE: &str = "/robot/pose_estimate";
    /// Absolute localisation fixes the robot received, in the world frame.
    pub const FIX: &str = "/robot/fix";
    /// The estimate's body outline, in the "robot_estimate" frame, which `/tf` moves.
    pub const ROBOT_ESTIMATE: &str = "/viz/robot_estimate";
}

/// JSON schema texts, by schema name.
pub mod schemas {
    /// `foxglove.FrameTransform` (from `@foxglove/schemas`, MIT).
    pub const FRAME_TRANSFORM: &str = include_str!("../schemas/foxglove.FrameTransform.json");
    /// `foxglove.PoseInFrame` (from `@foxglove/schemas`, MIT).
    pub const POSE_IN_FRAME: &str = include_str!("../schemas/foxglove.PoseInFrame.json");
    /// `foxglove.SceneUpdate` (from `@foxglove/schemas`, MIT).
    pub const SCENE_UPDATE: &str = include_str!("../schemas/foxglove.SceneUpdate.json");
    /// `foxglove.Grid` (from `@foxglove/schemas`, MIT).
    pub const GRID: &str = include_str!("../schemas/foxglove.Grid.json");
    /// `foxglove.Log` (from `@foxglove/schemas`, MIT).
    pub const LOG: &str = include_str!("../schemas/foxglove.Log.json");
    /// `mmq.Decision`.
    pub const DECISION: &str = include_str!("../schemas/mmq.Decision.json");
    /// `mmq.RewardEmitted`.
    pub const EMITTED: &str = include_str!("../schemas/mmq.RewardEmitted.json");
    /// `mmq.RewardDelivered`.
    pub const DELIVERED: &str = include_str!("../schemas/mmq.RewardDelivered.json");
    /// `mmq.Teleport`.
    pub const TELEPORT: &str = include_str!("../schemas/mmq.Teleport.json");
    /// `mmq.Contact`.
    pub const CONTACT: &str = include_str!("../schemas/mmq.Contact.json");
}

/// Every channel of an mmq log: (topic, schema name, schema text), in the order the
/// recorder registers them.
pub const CHANNELS: [(&str, &str, &str); 14] = [
    (topics::TF, "foxglove.FrameTransform", schemas::FRAME_TRANSFORM),
    (topics::POSE, "foxglove.PoseInFrame", schemas::POSE_IN_FRAME),
    (topics::ARENA, "foxglove.SceneUpdate", schemas::SCENE_UPDATE),
    (topics::ROBOT, "foxglove.SceneUpdate", schemas::SCENE_UPDATE),
    (topics::DECISION, "mmq.Decision", schemas::DECISION),
    (topics::EMITTED, "mmq.RewardEmitted", schemas::EMITTED),
    (topics::DELIVERED, "mmq.RewardDelivered", schemas::DELIVERED),
    (topics::TELEPORT, "mmq.Teleport", schemas::TELEPORT),
    (topics::CONTACT, "mmq.Contact", schemas::CONTACT),
    (topics::VISITS, "foxglove.Grid", schemas::GRID),
    (topics::VALUE, "foxglove.Grid", schemas::GRID),
    (topics::POSE_ESTIMATE, "foxglove.PoseInFrame", schemas::POSE_IN_FRAME),
    (topics::FIX, "foxglove.PoseInFrame", schemas::POSE_IN_FRAME),
    (topics::ROBOT_ESTIMATE, "foxglove.SceneUpdate", schemas::SCENE_UPDATE),
];

/// Topics whose last message stays true until replaced (the scenes, the heat maps): a
/// live view sends their last message to every new subscriber.
pub const LATCHED: [&str; 5] =
    [topics::ARENA, topics::ROBOT, topics::ROBOT_ESTIMATE, topics::VISITS, topics::VALUE];

/// The optional log channel (`foxglove.Log`).
pub const LOG_CHANNEL: (&str, &str, &str) = (topics::LOG, "foxglove.Log", schemas::LOG);

// ---------------------------------------------------------------------------------------
// Foxglove well-known messages.

/// `time`: a timestamp as seconds and nanoseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds.
    pub sec: u64,
    /// Nanoseconds, 0..1e9.
    pub nsec: u32,
}

impl Time {
    /// From nanoseconds.
    pub fn from_ns(ns: u64) -> Self {
        Self { sec: ns / 1_000_000_000, nsec: (ns % 1_000_000_000) as u32 }
    }
}

/// `foxglove.Vector2`.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector2 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
}

/// `foxglove.Vector3`.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

/// `foxglove.Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x value.
    pub x: f64,
    /// y value.
    pub y: f64,
    /// z value.
    pub z: f64,
    /// w value.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Quaternion {
    /// No rotation.
    pub const IDENTITY: Quaternion = Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 };

    /// A rotation by `theta` radians about +z (counter-clockwise seen from above).
    pub fn yaw(theta: f64) -> Self {
        let (s, c) = (0.5 * theta).sin_cos();
        Self { x: 0.0, y: 0.0, z: s, w: c }
    }

    /// The rotation about +z of a yaw-only quaternion, radians in (−π, π].
    pub fn to_yaw(self) -> f64 {
        2.0 * self.z.atan2(self.w)
    }
}

/// `foxglove.Pose`.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

impl Pose {
    /// A pose in the ground plane: position (x, y, z) and heading `theta` about +z.
    pub fn planar(x: f64, y: f64, z: f64, theta: f64) -> Self {
        Self { position: Vector3 { x, y, z }, orientation: Quaternion::yaw(theta) }
    }
}

/// `foxglove.Color` (components in 0..1).
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Color {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
    /// Alpha.
    pub a: f64,
}

impl Color {
    /// A colour from components in 0..1.
    pub const fn rgba(r: f64, g: f64, b: f64, a: f64) -> Self {
        Self { r, g, b, a }
    }
}

/// `foxglove.FrameTransform`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTransform {
    /// Timestamp of the transform.
    pub timestamp: Time,
    /// Parent frame.
    pub parent_frame_id: String,
    /// Child frame.
    pub child_frame_id: String,
    /// Translation of the child frame in the parent frame.
    pub translation: Vector3,
    /// Rotation of the child frame in the parent frame.
    pub rotation: Quaternion,
}

/// `foxglove.PoseInFrame`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseInFrame {
    /// Timestamp of the pose.
    pub timestamp: Time,
    /// Frame of reference.
    pub frame_id: String,
    /// The pose.
    pub pose: Pose,
}

/// `foxglove.KeyValuePair`.
#[derive(Clone, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct KeyValuePair {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `foxglove.ArrowPrimitive` (points along +x of its pose).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ArrowPrimitive {
    /// Pose of the tail.
    pub pose: Pose,
    /// Shaft length, metres.
    pub shaft_length: f64,
    /// Shaft diameter, metres.
    pub shaft_diameter: f64,
    /// Head length, metres.
    pub head_length: f64,
    /// Head diameter, metres.
    pub head_diameter: f64,
    /// Colour.
    pub color: Color,
}

/// `foxglove.CubePrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CubePrimitive {
    /// Pose of the centre.
    pub pose: Pose,
    /// Size along x, y, z, metres.
    pub size: Vector3,
    /// Colour.
    pub color: Color,
}

/// `foxglove.CylinderPrimitive` (axis along +z).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CylinderPrimitive {
    /// Pose of the centre.
    pub pose: Pose,
    /// Bounding box size, metres.
    pub size: Vector3,
    /// Bottom radius as a fraction of the bounding box.
    pub bottom_scale: f64,
    /// Top radius as a fraction of the bounding box.
    pub top_scale: f64,
    /// Colour.
    pub color: Color,
}

/// `foxglove.LineType`: 0 = LINE_STRIP, 1 = LINE_LOOP, 2 = LINE_LIST.
pub type LineType = u8;
/// One line through every point in order.
pub const LINE_STRIP: LineType = 0;
/// Individual segments 0-1, 2-3, ...
pub const LINE_LIST: LineType = 2;

/// `foxglove.LinePrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinePrimitive {
    /// Drawing primitive ([`LINE_LIST`], ...).
    #[serde(rename = "type")]
    pub kind: LineType,
    /// Pose of the points' frame.
    pub pose: Pose,
    /// Thickness (metres, or pixels when `scale_invariant`).
    pub thickness: f64,
    /// Thickness in pixels rather than metres.
    pub scale_invariant: bool,
    /// Points.
    pub points: Vec<Vector3>,
    /// Colour of the whole line.
    pub color: Color,
    /// Per-point colours (empty: use `color`).
    pub colors: Vec<Color>,
    /// Indices into `points` (empty: use all in order).
    pub indices: Vec<u32>,
}

/// `foxglove.TextPrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextPrimitive {
    /// Pose of the text.
    pub pose: Pose,
    /// Always face the camera.
    pub billboard: bool,
    /// Font size (metres, or pixels when `scale_invariant`).
    pub font_size: f64,
    /// Font size in pixels rather than metres.
    pub scale_invariant: bool,
    /// Colour.
    pub color: Color,
    /// The text.
    pub text: String,
}

/// `foxglove.SceneEntity`. Only the primitive kinds mmq draws are typed; the others are
/// written as the empty arrays the schema requires.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneEntity {
    /// Timestamp of the entity.
    pub timestamp: Time,
    /// Frame the entity is drawn in.
    pub frame_id: String,
    /// Id (a later entity with the same id replaces it).
    pub id: String,
    /// How long it is shown; zero = until replaced.
    pub lifetime: Time,
    /// Follow the frame as it moves (rather than stay where it was drawn).
    pub frame_locked: bool,
    /// Extra key/value pairs.
    pub metadata: Vec<KeyValuePair>,
    /// Arrows.
    pub arrows: Vec<ArrowPrimitive>,
    /// Cubes.
    pub cubes: Vec<CubePrimitive>,
    /// Spheres (unused by mmq).
    pub spheres: Vec<serde_json::Value>,
    /// Cylinders.
    pub cylinders: Vec<CylinderPrimitive>,
    /// Lines.
    pub lines: Vec<LinePrimitive>,
    /// Triangles (unused by mmq).
    pub triangles: Vec<serde_json::Value>,
    /// Texts.
    pub texts: Vec<TextPrimitive>,
    /// Models (unused by mmq).
    pub models: Vec<serde_json::Value>,
}

impl SceneEntity {
    /// An empty entity `id` in `frame_id`, shown until replaced.
    pub fn new(timestamp: Time, frame_id: &str, id: &str) -> Self {
        Self {
            timestamp,
            frame_id: frame_id.into(),
            id: id.into(),
            lifetime: Time::default(),
            frame_locked: false,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            lines: Vec::new(),
            triangles: Vec::new(),
            texts: Vec::new(),
            models: Vec::new(),
        }
    }
}

/// `foxglove.SceneUpdate`.
#[derive(Clone, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct SceneUpdate {
    /// Entities to delete (unused by mmq: entities are replaced by id).
    pub deletions: Vec<serde_json::Value>,
    /// Entities to add or replace.
    pub entities: Vec<SceneEntity>,
}

/// `foxglove.NumericType` FLOAT32.
pub const FLOAT32: u8 = 7;

/// `foxglove.PackedElementField`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PackedElementField {
    /// Field name.
    pub name: String,
    /// Byte offset inside a cell.
    pub offset: u32,
    /// `foxglove.NumericType` ([`FLOAT32`], ...).
    #[serde(rename = "type")]
    pub kind: u8,
}

/// `foxglove.Grid`: row-major (y-major) cells starting at the corner given by `pose`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Timestamp of the grid.
    pub timestamp: Time,
    /// Frame of reference.
    pub frame_id: String,
    /// Pose of the grid's origin corner.
    pub pose: Pose,
    /// Number of columns.
    pub column_count: u32,
    /// Size of one cell, metres.
    pub cell_size: Vector2,
    /// Bytes between rows in `data`.
    pub row_stride: u32,
    /// Bytes between cells in a row.
    pub cell_stride: u32,
    /// Fields of each cell.
    pub fields: Vec<PackedElementField>,
    /// Cell data, base64.
    pub data: String,
}

/// `foxglove.LogLevel` INFO.
pub const LOG_INFO: u8 = 2;
/// `foxglove.LogLevel` WARNING.
pub const LOG_WARNING: u8 = 3;

/// `foxglove.Log`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Log {
    /// Timestamp.
    pub timestamp: Time,
    /// `foxglove.LogLevel` ([`LOG_INFO`], ...).
    pub level: u8,
    /// The message.
    pub message: String,
    /// Process or node name.
    pub name: String,
    /// Source file.
    pub file: String,
    /// Source line.
    pub line: u32,
}

// ---------------------------------------------------------------------------------------
// mmq's own messages (schemas in `schemas/mmq.*.json`).

/// `mmq.Decision` on `/rl/decision`: one decision step and its outcome.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// Decision step t.
    pub t: u64,
    /// State s_t.
    pub state: u64,
    /// Action a_t.
    pub action: u64,
    /// Name of a_t.
    pub action_name: String,
    /// The delay model the learner acted on (MMQ's λ̂*), if any; left out of the JSON
    /// when there is none (Foxglove's JSON schema support has no `null` type).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<u64>,
    /// Exploratory (ε) rather than greedy.
    pub explored: bool,
    /// State s_{t+1}.
    pub next_state: u64,
    /// What happened (`moved`, `wall`, `goal`, `timeout`).
    pub event: String,
}

/// `mmq.RewardEmitted` on `/rl/reward/emitted`: a non-zero reward entering the channel.
///
/// A delay in steps is known in steps at once (`delay`, `due`); a delay in seconds is
/// drawn in seconds (`delay_s`, `due_s`) and its steps are known only at delivery (the
/// delivery's [`DeliveredPart::delay`]), so `delay` and `due` are absent then. Absent
/// fields are left out of the JSON (Foxglove's JSON schema support has no `null`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RewardEmitted {
    /// Emission id (as in the ledger).
    pub id: u64,
    /// Step of the emission.
    pub t: u64,
    /// Value.
    pub value: f64,
    /// `wall`, `goal` or `step`.
    pub cause: String,
    /// Delay drawn, steps (a delay in steps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay: Option<u32>,
    /// Step of delivery, `t + delay` (a delay in steps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub due: Option<u64>,
    /// Simulated time of the emission (the end of step `t`), seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_emit_s: Option<f64>,
    /// Delay drawn, seconds of simulated time (a delay in seconds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_s: Option<f64>,
    /// When it falls due, `t_emit_s + delay_s`, seconds: it is delivered with the first
    /// decision that ends at or after it (a delay in seconds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub due_s: Option<f64>,
    /// Running total of emitted reward (this one included).
    pub total: f64,
}

/// One emission inside a delivery.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeliveredPart {
    /// Emission id.
    pub id: u64,
    /// Step of the emission.
    pub t_emit: u64,
    /// Its delay, steps (delivery step − emission step).
    pub delay: u32,
    /// Its value.
    pub value: f64,
    /// Simulated time of the emission, seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_emit_s: Option<f64>,
    /// Its delay in seconds: from the emission to the end of the delivering step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_s: Option<f64>,
    /// The delay drawn, seconds (a delay in seconds: `delay_s` is it plus the wait for
    /// the end of the delivering decision).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drawn_s: Option<f64>,
}

/// `mmq.RewardDelivered` on `/rl/reward/delivered`: what the learner received at a step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RewardDelivered {
    /// Step of the delivery.
    pub t: u64,
    /// Sum delivered.
    pub sum: f64,
    /// Ids of the emissions it contains (empty without a ledger).
    pub ids: Vec<u64>,
    /// The emissions it contains (empty without a ledger).
    pub parts: Vec<DeliveredPart>,
    /// Running total of delivered reward (this one included).
    pub total: f64,
}

/// A point in the world frame, metres.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Point2 {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
}

/// `mmq.Teleport` on `/rl/teleport`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Teleport {
    /// Step of the teleport.
    pub t: u64,
    /// State before (the goal).
    pub from_state: u64,
    /// State after (the respawn cell).
    pub to_state: u64,
    /// Centre of the cell before.
    pub from: Point2,
    /// Centre of the cell after.
    pub to: Point2,
}

/// `mmq.Contact` on `/sim/contact`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Decision step during which it happened.
    pub t: u64,
    /// Simulated time since the start of the run, seconds.
    pub time_s: f64,
    /// Started (true) or stopped (false).
    pub started: bool,
    /// Which wall.
    pub wall: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schemas_are_json_and_named_as_registered() {
        for (_, name, text) in CHANNELS.iter().chain([&LOG_CHANNEL]) {
            let v: serde_json::Value = serde_json::from_str(text).unwrap();
            assert_eq!(v["title"], *name);
        }
    }

    #[test]
    fn yaw_round_trips() {
        for th in [0.0, 1.0, -2.5, 3.0] {
            assert!((Quaternion::yaw(th).to_yaw() - th).abs() < 1e-12);
        }
        assert_eq!(Time::from_ns(3_000_000_007), Time { sec: 3, nsec: 7 });
    }
}
