//! System tests and the evaluation harness: the simulated world against the fusion core,
//! the seed's method and an oracle, scored against ground truth; and recorded ball tracks
//! (`tracks`, `track_*`), observed by simulated robots and scored against themselves; and
//! the robot agent driven by the simulator (`sim_source`, `agent_recall`, `sim_patches`,
//! behind the `sim_agent`, `bench_agent`, `sim_calibrate` and `train_sim` binaries); and the
//! load test of a server process fed by many robots at once (`load`, `load_report`).

pub mod agent_recall;
pub mod baseline;
pub mod bench;
pub mod eval;
pub mod fuzz;
pub mod line_fit;
pub mod load;
pub mod load_report;
pub mod logging;
pub mod methods;
pub mod photo_eval;
pub mod photo_set;
pub mod plot;
pub mod plots;
pub mod progress;
pub mod report;
pub mod scoring;
pub mod sim_args;
pub mod sim_log;
pub mod sim_patches;
pub mod sim_robots;
pub mod sim_source;
pub mod track_cases;
pub mod track_eval;
pub mod track_events;
pub mod track_fixtures;
pub mod track_obs;
pub mod track_report;
pub mod tracks;
pub mod vision;
pub mod vision_report;
