//! The evaluation and its reports.
//!
//! - **The simulator's scenarios**: [`scenarios`] runs every scenario over many seeds and every
//!   method in [`methods`] (the fusion core, the seed's method in [`baseline`], a plain
//!   [`line_fit`], an oracle) on the same deliveries; [`report`] pools and checks targets;
//!   [`plots`] draws them.
//! - **Ball tracks** (CSV, recorded or made): [`track_obs`] observes a track by simulated
//!   robots, [`track_events`] finds its bounces and kicks, [`track_eval`] scores every method
//!   and [`track_report`] writes the tables and the chart.
//! - **Vision**: [`vision`] runs rendered cameras through the real agent pipeline and
//!   [`vision_report`] reports it; [`photo_eval`] scores the detector on photos;
//!   [`teacher_eval`] scores a labeller (the teacher) box by box.
//! - [`plot`]: the drawing primitives of every chart.
//!
//! Binary: `evaluate`.

pub mod baseline;
pub mod line_fit;
pub mod methods;
pub mod photo_eval;
pub mod plot;
pub mod plots;
pub mod report;
pub mod scenarios;
pub mod teacher_eval;
pub mod track_eval;
pub mod track_events;
pub mod track_obs;
pub mod track_report;
pub mod vision;
pub mod vision_report;
