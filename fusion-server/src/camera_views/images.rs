//! Camera views as Foxglove draws them: a `foxglove.CompressedImage` and a
//! `foxglove.ImageAnnotations` per camera (the ball bold green, runners-up yellow, rejected
//! candidates red with their reason, the rest faint), and the split a match log stores a
//! view in: the JPEG once, in the image channel, and the view's metadata (its
//! `jpeg_base64` empty) on the view's own key; [`rejoin`] puts them back together.

use crate::camera_views::StoredView;
use crate::matchlog::read::LogMessage;
use crate::matchlog::record::Schema;
use crate::scene::encode;
use foxglove::messages::{
    CircleAnnotation, Color, CompressedImage, ImageAnnotations, Point2, TextAnnotation,
};
use foxglove::{Decode, Encode as _};
use proto::{CameraView, CandidateOutcome, Stamp, camera_chunk};
use std::sync::Arc;

/// Schema name of the image channels.
pub const IMAGE_SCHEMA: &str = "foxglove.CompressedImage";
/// Schema name of the annotation channels.
pub const ANNOTATIONS_SCHEMA: &str = "foxglove.ImageAnnotations";
/// Schema name of the views' own channels (the wire message).
pub const VIEW_SCHEMA: &str = "CameraView";

/// `/robots/{id}/{camera}/image`.
pub fn image_topic(view: &CameraView) -> String {
    format!(
        "/robots/{}/{}/image",
        view.robot_id,
        camera_chunk(view.camera)
    )
}

/// `/robots/{id}/{camera}/annotations`.
pub fn annotations_topic(view: &CameraView) -> String {
    format!(
        "/robots/{}/{}/annotations",
        view.robot_id,
        camera_chunk(view.camera)
    )
}

/// The image's frame: `{id}/{camera}`.
pub fn frame_id(view: &CameraView) -> String {
    format!("{}/{}", view.robot_id, camera_chunk(view.camera))
}

/// The schemas of the image and annotation channels: Foxglove's protobuf descriptors.
pub fn schemas() -> Vec<Arc<Schema>> {
    crate::scene::protobuf_schemas([
        CompressedImage::get_schema(),
        ImageAnnotations::get_schema(),
    ])
}

fn timestamp(stamp: Stamp) -> foxglove::messages::Timestamp {
    crate::scene::timestamp(stamp)
}

/// The view's image, stamped with its capture time.
pub fn compressed_image(v: &StoredView) -> CompressedImage {
    CompressedImage {
        timestamp: Some(timestamp(v.meta.stamp)),
        frame_id: frame_id(&v.meta),
        data: v.jpeg.to_vec().into(),
        format: "jpeg".into(),
    }
}

fn rgba(r: f64, g: f64, b: f64, a: f64) -> Color {
    Color { r, g, b, a }
}

/// What the view's candidates look like on the image.
pub fn annotations(view: &CameraView) -> ImageAnnotations {
    let mut circles = Vec::with_capacity(view.candidates.len());
    let mut texts = Vec::new();
    for c in &view.candidates {
        let (colour, thickness, label) = match c.outcome {
            CandidateOutcome::Ball => (
                rgba(0.2, 0.95, 0.3, 1.0),
                3.0,
                format!("ball {:.2}", c.score),
            ),
            CandidateOutcome::RunnerUp => {
                (rgba(1.0, 0.85, 0.1, 0.9), 1.5, format!("{:.2}", c.score))
            }
            CandidateOutcome::Rejected => (
                rgba(1.0, 0.3, 0.25, 0.6),
                1.0,
                format!(
                    "{:.2} {}",
                    c.score,
                    c.reason.as_deref().unwrap_or("rejected")
                ),
            ),
        };
        circles.push(CircleAnnotation {
            timestamp: Some(timestamp(view.stamp)),
            position: Some(Point2 {
                x: c.u_px,
                y: c.v_px,
            }),
            diameter: 2.0 * c.radius_px,
            thickness,
            fill_color: Some(rgba(0.0, 0.0, 0.0, 0.0)),
            outline_color: Some(colour),
            metadata: Vec::new(),
        });
        if c.outcome != CandidateOutcome::Rejected || c.score >= 0.2 {
            texts.push(TextAnnotation {
                timestamp: Some(timestamp(view.stamp)),
                position: Some(Point2 {
                    x: c.u_px + c.radius_px + 2.0,
                    y: c.v_px,
                }),
                text: label,
                font_size: 10.0,
                text_color: Some(colour),
                background_color: Some(rgba(0.0, 0.0, 0.0, 0.5)),
                metadata: Vec::new(),
            });
        }
    }
    ImageAnnotations {
        timestamp: Some(timestamp(view.stamp)),
        circles,
        points: Vec::new(),
        texts,
        metadata: Vec::new(),
    }
}

/// One record of a view for a match log or Foxglove.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewRecord {
    pub topic: String,
    pub schema: &'static str,
    pub payload: Vec<u8>,
}

/// A kept view as a match log stores it, in this order: the image, the annotations, and
/// the metadata on the view's key (`jpeg_base64` empty: the image is in the first record).
pub fn records(v: &StoredView) -> [ViewRecord; 3] {
    [
        ViewRecord {
            topic: image_topic(&v.meta),
            schema: IMAGE_SCHEMA,
            payload: encode(&compressed_image(v)),
        },
        ViewRecord {
            topic: annotations_topic(&v.meta),
            schema: ANNOTATIONS_SCHEMA,
            payload: encode(&annotations(&v.meta)),
        },
        ViewRecord {
            topic: v.key.clone(),
            schema: VIEW_SCHEMA,
            payload: proto::encode(&v.meta),
        },
    ]
}

/// How far back from a view's metadata [`rejoin`] looks for its image.
const REJOIN_WINDOW: usize = 64;

/// A log's views made whole again: each `CameraView` message with an empty `jpeg_base64`
/// takes the JPEG of the image logged just before it for the same camera at the same time.
/// A view whose image is not found is left as it is (a receiver refuses it as not a JPEG).
pub fn rejoin(messages: &mut [LogMessage]) -> usize {
    let mut joined = 0;
    for i in 0..messages.len() {
        if messages[i].schema_name != VIEW_SCHEMA {
            continue;
        }
        let Ok(mut view) = proto::decode::<CameraView>(&messages[i].data) else {
            continue;
        };
        if !view.jpeg_base64.is_empty() {
            continue;
        }
        let topic = image_topic(&view);
        let at = messages[i].log_time;
        let image = messages[i.saturating_sub(REJOIN_WINDOW)..i]
            .iter()
            .rev()
            .find(|m| m.schema_name == IMAGE_SCHEMA && m.topic == topic && m.log_time == at)
            .and_then(|m| CompressedImage::decode(m.data.as_slice()).ok());
        if let Some(image) = image {
            view.jpeg_base64 = proto::jpeg_base64(&image.data);
            messages[i].data = proto::encode(&view);
            joined += 1;
        }
    }
    joined
}
