//! Match logs: MCAP files Foxglove opens. [`record`] writes them on a background thread
//! (rotating, crash-safe chunks), [`McapLog`] is the live server's log and [`RecorderSink`]
//! an offline tool's; [`read`] reads them back, including logs cut short by a crash;
//! [`replay`] re-fuses them offline and [`replay_live`] plays them as if live, under the
//! control of the coach's page.

pub mod read;
pub mod record;
pub mod replay;
pub mod replay_live;
mod writer;

pub use writer::{McapLog, RecorderSink, schemas};
