//! `bench_agent`: the robot agent's perception pipeline's time per frame on one core, by
//! stage, on frames rendered from simulated matches; the cost of a camera view (downscale,
//! JPEG and annotations, built on its own thread in the agent); and the renderer's own
//! speed.
//!
//! Flags: `--matches N` (default 3), `--seconds S` (default 20), `--detector
//! two-stage|net|dissertation` (default: the robot's), `--model FILE`, `--doc FILE`.
//!
//! Frames are rendered first (not timed), then each goes through the agent's whole
//! pipeline (colour mask to floor projection and validation) on this thread, with every
//! stage timed. `--doc FILE` rewrites the generated section of the benchmarks page.

use anyhow::{Context, Result};
use clap::Parser;
use proto::{Camera, Pitch, Stamp};
use robot_agent::{Agent, FrameInput, PipelineConfig};
use robot_agent::{DetectorArgs, DetectorKind, load_models};
use sim::CameraRig;
use sim::LensModel;
use sim::{CameraWorld, CameraWorldConfig};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;
use vision::RgbImage;
use vision::StageClock;

#[derive(Debug, Parser)]
#[command(
    name = "bench_agent",
    about = "Times the agent's perception pipeline per frame, by stage, on rendered frames"
)]
struct BenchArgs {
    /// The detector timed (the robot's by default); each has its own section of the
    /// document.
    #[command(flatten)]
    detector: DetectorArgs,
    /// Simulated matches the frames come from.
    #[arg(long, default_value_t = 3)]
    matches: u64,
    /// Seconds of each match (both cameras of every robot at 5 Hz).
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Time the detector on real photos instead of rendered frames: the photos of these
    /// folders (repeatable; subfolders included) scaled and cropped to a 640×360 frame, as
    /// a camera of the MiRo's size would give them. Its section is marked with `-photos`.
    #[arg(long, value_name = "DIR")]
    photos: Vec<PathBuf>,
    /// With `--photos`: at most this many photos of each folder, spread over it.
    #[arg(long, default_value_t = 400, requires = "photos")]
    photo_count: usize,
    /// Rewrite the generated section of this markdown file.
    #[arg(long)]
    doc: Option<PathBuf>,
}

/// The document's section for a detector: `bench-vision` for the robot's, with the
/// detector's name for another, then `suffix` (`-photos` for real photos, or none).
fn section(kind: DetectorKind, suffix: &str) -> (String, String) {
    let name = if kind == DetectorKind::default() {
        format!("bench-vision{suffix}")
    } else {
        format!("bench-vision-{}{suffix}", kind.name())
    };
    (
        format!("<!-- {name}:begin -->"),
        format!("<!-- {name}:end -->"),
    )
}

/// Rewrites the detector's section (with its suffix) of the markdown file `path` with
/// `table`, under the command that repeats the run (`flags`, then the detector's own).
fn write_doc(
    path: &std::path::Path,
    detector: &DetectorArgs,
    suffix: &str,
    flags: &str,
    table: &str,
) -> Result<()> {
    let (begin, end) = section(detector.kind, suffix);
    let cmd = format!(
        "cargo run --release -p bench --bin bench_agent --{flags}{} --doc {}",
        detector.command_line(),
        path.display()
    );
    let section = format!("Produced by `{cmd}`.\n\n{table}");
    eval::report::rewrite_section_between(path, &begin, &end, &section)
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("updated {}", path.display());
    Ok(())
}

/// Every stage's durations, milliseconds, in pipeline order.
#[derive(Debug, Default)]
struct Stages {
    order: Vec<&'static str>,
    ms: BTreeMap<&'static str, Vec<f64>>,
}

/// Records each stage's duration per frame.
struct Recorder<'a> {
    stages: &'a mut Stages,
    last: Instant,
}

impl StageClock for Recorder<'_> {
    fn mark(&mut self, stage: &'static str) {
        let now = Instant::now();
        if !self.stages.order.contains(&stage) {
            self.stages.order.push(stage);
        }
        self.stages
            .ms
            .entry(stage)
            .or_default()
            .push(now.duration_since(self.last).as_secs_f64() * 1e3);
        self.last = now;
    }
}

/// Frames whose views are timed (spread over the run).
const VIEW_SAMPLES: usize = 60;

/// The agent's default views per second per camera (`--view-hz`).
const VIEW_HZ: f64 = 2.0;

/// The `q` quantile of the times (the workspace's one definition); NaN for none.
fn quantile(v: &[f64], q: f64) -> f64 {
    proto::stats::quantile(v, q).unwrap_or(f64::NAN)
}

/// A frame whose view is timed, with the pipeline's outcome and time on it.
struct ViewSample<'a> {
    stamp: Stamp,
    camera: Camera,
    image: &'a RgbImage,
    robot_id: &'a str,
    result: robot_agent::FrameResult,
    pipeline_ms: f64,
}

/// What building a camera view costs.
#[derive(Debug)]
struct ViewCost {
    /// Views built.
    count: usize,
    /// Median time to build one, milliseconds.
    median_ms: f64,
    /// Median JPEG size, bytes.
    median_bytes: f64,
    /// The views' size, pixels.
    size_px: (u32, u32),
    /// Median time the perception thread spends handing a frame over (its copy and its
    /// candidates), milliseconds.
    handoff_ms: f64,
}

impl ViewCost {
    /// The line of the report: the view's time, and that time as a share of the
    /// pipeline's at `--view-hz 2` per camera against frames at `fps` per camera.
    fn line(&self, fps: f64, pipeline_ms: f64) -> String {
        let share = self.median_ms * VIEW_HZ / fps / pipeline_ms * 100.0;
        let core = self.median_ms * VIEW_HZ * 2.0 / 1e3 * 100.0;
        let handoff = self.handoff_ms * VIEW_HZ / fps / pipeline_ms * 100.0;
        format!(
            "A camera view (640×360 frame area-averaged to {}×{}, JPEG, its candidates; {} views, median {:.1} kB) takes {:.2} ms median to build, on the agent's view thread, which this keeps {core:.2} % busy for both cameras at the default {VIEW_HZ} views a second per camera (were it on the perception thread, it would add {share:.1} % to the pipeline's time per frame at the frames' {fps:.1} frames a second per camera). The perception thread itself only copies a frame and its candidates when a view is due: {:.3} ms median, {handoff:.2} % of the pipeline's time per frame (copy ms × {VIEW_HZ} Hz ÷ frames a second ÷ pipeline ms per frame × 100).\n\n",
            self.size_px.0,
            self.size_px.1,
            self.count,
            self.median_bytes / 1e3,
            self.median_ms,
            self.handoff_ms,
        )
    }
}

/// Times the view of every sampled frame.
fn time_views(samples: &[ViewSample<'_>]) -> Result<ViewCost> {
    let mut ms = Vec::with_capacity(samples.len());
    let mut bytes = Vec::with_capacity(samples.len());
    let mut size_px = (0, 0);
    let mut handoff = Vec::with_capacity(samples.len());
    for (seq, v) in samples.iter().enumerate() {
        let started = Instant::now();
        let copied = std::hint::black_box((v.image.clone(), v.result.clone()));
        handoff.push(started.elapsed().as_secs_f64() * 1e3);
        drop(copied);
        let started = Instant::now();
        let view = robot_agent::camera_view(
            v.robot_id,
            seq as u64,
            v.camera,
            v.stamp,
            v.image,
            &v.result,
            v.pipeline_ms,
        )?;
        ms.push(started.elapsed().as_secs_f64() * 1e3);
        bytes.push(view.jpeg()?.len() as f64);
        size_px = (view.width_px, view.height_px);
    }
    Ok(ViewCost {
        count: ms.len(),
        median_ms: quantile(&ms, 0.5),
        median_bytes: quantile(&bytes, 0.5),
        size_px,
        handoff_ms: quantile(&handoff, 0.5),
    })
}

/// Frames a second of each camera, from a match's frame times (seconds).
fn frame_rate_hz(times_s: &[f64]) -> Option<f64> {
    let (first, last) = (times_s.first()?, times_s.last()?);
    (last > first).then(|| (times_s.len() - 1) as f64 / (last - first))
}

/// A photo as a 640×360 frame: scaled by area averaging (or nearest pixel, when enlarged)
/// to cover the frame, its middle kept.
fn as_frame(photo: &RgbImage) -> Result<RgbImage> {
    const W: u32 = 640;
    const H: u32 = 360;
    let (pw, ph) = (f64::from(photo.width()), f64::from(photo.height()));
    // Source pixels per frame pixel, so the scaled photo covers the whole frame.
    let step = (pw / f64::from(W)).min(ph / f64::from(H));
    let x0 = (pw - step * f64::from(W)) / 2.0;
    let y0 = (ph - step * f64::from(H)) / 2.0;
    let data = photo.data();
    let stride = photo.width() as usize;
    let mut out = Vec::with_capacity((W * H * 3) as usize);
    for y in 0..H {
        let sy0 = (y0 + step * f64::from(y)) as usize;
        let sy1 = ((y0 + step * f64::from(y + 1)) as usize)
            .max(sy0 + 1)
            .min(photo.height() as usize);
        for x in 0..W {
            let sx0 = (x0 + step * f64::from(x)) as usize;
            let sx1 = ((x0 + step * f64::from(x + 1)) as usize)
                .max(sx0 + 1)
                .min(stride);
            let mut acc = [0u32; 3];
            for sy in sy0..sy1 {
                for px in data[(sy * stride + sx0) * 3..(sy * stride + sx1) * 3].chunks_exact(3) {
                    for k in 0..3 {
                        acc[k] += u32::from(px[k]);
                    }
                }
            }
            let n = ((sy1 - sy0) * (sx1 - sx0)).max(1) as u32;
            out.extend(acc.map(|a| (a / n) as u8));
        }
    }
    Ok(RgbImage::new(W, H, out)?)
}

/// `--photos`: the detector's time per frame by stage on real photos made 640×360 frames
/// (no pose, so no projection: the image half and the classifier).
fn bench_photos(args: &BenchArgs, dirs: &[PathBuf]) -> Result<()> {
    let config = PipelineConfig::default();
    let chosen = args.detector.choose(&config.detector)?;
    let mut frames = Vec::new();
    for dir in dirs {
        let mut files = robot_agent::image_files_recursive(dir)?;
        files.sort();
        anyhow::ensure!(!files.is_empty(), "{} holds no photos", dir.display());
        let step = files.len().div_ceil(args.photo_count.max(1)).max(1);
        for file in files.iter().step_by(step) {
            match robot_agent::load_rgb(file) {
                Ok(photo) => frames.push(as_frame(&photo)?),
                Err(e) => eprintln!("{}: left out: {e}", file.display()),
            }
        }
    }
    let names: Vec<String> = dirs
        .iter()
        .map(|d| {
            d.file_name().map_or_else(
                || d.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect();
    eprintln!("{} photos as 640×360 frames", frames.len());
    let mut stages = Stages::default();
    let mut totals = Vec::with_capacity(frames.len());
    let mut found = 0usize;
    for frame in &frames {
        let started = Instant::now();
        let mut clock = Recorder {
            stages: &mut stages,
            last: started,
        };
        let candidates =
            chosen
                .detector
                .detect(frame, None, chosen.classifier.as_ref(), &mut clock)?;
        totals.push(started.elapsed().as_secs_f64() * 1e3);
        found += usize::from(
            candidates
                .iter()
                .any(|c| c.probability >= config.validation.min_probability),
        );
    }
    let mut table = format!(
        "Measured on one core of a 2-core machine: {} real photos of `{}` made 640×360 frames (scaled to cover the frame, its middle kept), {found} with a candidate at or above `min_probability`; no pose, so no projection.\n\n| stage | median ms | p99 ms |\n|---|---|---|\n",
        frames.len(),
        names.join("` and `"),
    );
    for stage in &stages.order {
        let mut v = stages.ms.get(stage).cloned().unwrap_or_default();
        v.sort_by(f64::total_cmp);
        table += &format!(
            "| {stage} | {:.3} | {:.3} |\n",
            quantile(&v, 0.5),
            quantile(&v, 0.99)
        );
    }
    totals.sort_by(f64::total_cmp);
    let (median, p99) = (quantile(&totals, 0.5), quantile(&totals, 0.99));
    table += &format!("| **whole detector** | **{median:.3}** | **{p99:.3}** |\n\n");
    let met = if median <= 2.0 { "met" } else { "missed" };
    table += &format!("Target: ≤ 2 ms per frame median: {met}.\n");
    println!("{table}");
    if let Some(path) = &args.doc {
        let folders: Vec<String> = dirs
            .iter()
            .map(|d| format!(" --photos {}", d.display()))
            .collect();
        let flags = format!("{} --photo-count {}", folders.concat(), args.photo_count);
        write_doc(path, &args.detector, "-photos", &flags, &table)?;
    }
    Ok(())
}

fn main() -> Result<()> {
    let args = BenchArgs::parse();
    if !args.photos.is_empty() {
        return bench_photos(&args, &args.photos);
    }
    let rig = CameraRig::new(LensModel::miro());
    let [left, right] = load_models(None, None)?;
    let config = PipelineConfig::default();
    // Chosen once, as every command chooses it: the model file is read here, not per robot.
    let chosen = args.detector.choose(&config.detector)?;
    let mut frames = Vec::new();
    let mut render_s = 0.0;
    let mut frame_rates = Vec::new();
    for m in 0..args.matches {
        let cfg = sim::SimConfig {
            duration_s: Some(args.seconds),
            ..sim::SimConfig::default()
        };
        let run = sim::run_scenario("match", 100 + m, &cfg)?;
        let cam = CameraWorldConfig {
            frame_rate_hz: 5.0,
            ..CameraWorldConfig::default()
        };
        let world = CameraWorld::new(&run, &rig, cam, 100 + m);
        let times: Vec<f64> = world.frame_times().collect();
        frame_rates.extend(frame_rate_hz(&times));
        for (k, t) in times.into_iter().enumerate() {
            for r in &run.robots {
                let started = Instant::now();
                let capture = world.capture(&r.id, t, k as u64);
                render_s += started.elapsed().as_secs_f64();
                for ((frame, _), camera) in capture
                    .frames
                    .into_iter()
                    .zip([Camera::Left, Camera::Right])
                {
                    let image = RgbImage::new(frame.width, frame.height, frame.rgb)?;
                    frames.push((
                        run.stamp_of(t),
                        camera,
                        image,
                        capture.reading,
                        r.id.clone(),
                    ));
                }
            }
        }
        eprintln!(
            "rendered match {}/{}: {} frames so far",
            m + 1,
            args.matches,
            frames.len()
        );
    }
    let mut stages = Stages::default();
    let mut totals = Vec::with_capacity(frames.len());
    let mut agents: BTreeMap<String, Agent> = BTreeMap::new();
    // Some frames' outcomes, with their pipeline times, to time their views after.
    let view_every = (frames.len() / VIEW_SAMPLES).max(1);
    let mut view_samples = Vec::with_capacity(VIEW_SAMPLES + 1);
    for (k, (stamp, camera, image, reading, id)) in frames.iter().enumerate() {
        let agent = match agents.get_mut(id) {
            Some(a) => a,
            None => {
                let a = Agent::new(id, Pitch::default(), config, [left, right], chosen.clone());
                agents.entry(id.clone()).or_insert(a)
            }
        };
        let input = FrameInput {
            stamp: *stamp,
            camera: *camera,
            image,
            pose: reading.pose,
            pose_covariance: reading.pose_covariance,
            head: reading.head,
        };
        let started = Instant::now();
        let mut clock = Recorder {
            stages: &mut stages,
            last: started,
        };
        let outcome = agent.on_frame(&input, &mut clock).context("pipeline")?;
        let ms = started.elapsed().as_secs_f64() * 1e3;
        totals.push(ms);
        if k % view_every == 0 {
            view_samples.push(ViewSample {
                stamp: *stamp,
                camera: *camera,
                image,
                robot_id: id,
                result: outcome.result,
                pipeline_ms: ms,
            });
        }
    }
    let views = time_views(&view_samples)?;
    let fps = quantile(&frame_rates, 0.5);
    let observations: u64 = agents.values().map(Agent::observations).sum();
    let mut rows = Vec::new();
    for stage in &stages.order {
        let mut v = stages.ms.get(stage).cloned().unwrap_or_default();
        v.sort_by(f64::total_cmp);
        rows.push((stage.to_string(), quantile(&v, 0.5), quantile(&v, 0.99)));
    }
    totals.sort_by(f64::total_cmp);
    let (median, p99) = (quantile(&totals, 0.5), quantile(&totals, 0.99));
    let render_fps = frames.len() as f64 / render_s.max(1e-9);
    let mut table = format!(
        "Measured on one core of a 2-core machine: {} frames (640×360) from {} simulated matches, {} with a ball found.\n\n| stage | median ms | p99 ms |\n|---|---|---|\n",
        frames.len(),
        args.matches,
        observations
    );
    for (stage, m, p) in &rows {
        table += &format!("| {stage} | {m:.3} | {p:.3} |\n");
    }
    let met = if median <= 2.0 { "met" } else { "missed" };
    table += &format!("| **whole pipeline** | **{median:.3}** | **{p99:.3}** |\n\n");
    table += &format!("Target: ≤ 2 ms per frame median for the whole pipeline: {met}.\n\n");
    table += &views.line(fps, median);
    table += &format!(
        "The camera renderer (640×360, the ball and the other robots in view, sensor noise) renders {render_fps:.0} camera frames per second on one core (target ≥ 100).\n"
    );
    if let Some(net) = chosen.detector.candidate_net()
        && chosen.kind == DetectorKind::TwoStage
    {
        let checker = robot_agent::builtin::checker()?;
        table += &format!(
            "\nThe candidate network does {:.1} M multiply-adds per 640×360 frame; the grey checker {:.2} M per candidate patch.\n",
            net.multiply_adds(640, 360) as f64 / 1e6,
            checker.multiply_adds() as f64 / 1e6
        );
        // Reading both networks from the shipped file's bytes, as the agent does at start.
        let bytes = robot_agent::builtin::DETECTOR;
        let mut load_ms = Vec::new();
        for _ in 0..20 {
            let started = Instant::now();
            vision::stages::candidates::HeatNet::from_safetensors(bytes)?;
            vision::stages::checker::Checker::from_safetensors(bytes)?;
            load_ms.push(started.elapsed().as_secs_f64() * 1e3);
        }
        load_ms.sort_by(f64::total_cmp);
        table += &format!(
            "The weights file is {} kB; reading both networks from it takes {:.2} ms (median of 20).\n",
            bytes.len() / 1000,
            load_ms[load_ms.len() / 2]
        );
    }
    if let Some(net) = chosen.detector.candidate_net()
        && chosen.kind == DetectorKind::Net
    {
        table += &format!(
            "\nThe candidate network does {:.1} M multiply-adds per 640×360 frame.\n",
            net.multiply_adds(640, 360) as f64 / 1e6,
        );
    }
    println!("{table}");
    if let Some(path) = &args.doc {
        let flags = format!(" --matches {} --seconds {}", args.matches, args.seconds);
        write_doc(path, &args.detector, "", &flags, &table)?;
    }
    Ok(())
}
