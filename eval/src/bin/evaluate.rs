//! `evaluate`: every scenario over many seeds, each method on the same observations,
//! scored against the simulator's ground truth. Writes JSON, prints a markdown table and
//! the targets, and draws PNG plots. With `--vision`, the seed's scenarios are rendered
//! through the robots' cameras and the real agent pipeline supplies the observations.
//! With `--tracks`, recorded ball tracks are observed by simulated robots and every method
//! is scored against the tracks themselves (`tracks_cmd`). With `--labelled DIR`, the
//! agent's detectors are scored on real labelled photos, a row per event (`labelled_cmd`).

#[path = "evaluate/labelled_cmd.rs"]
mod labelled_cmd;
#[path = "evaluate/sorted_cmd.rs"]
mod sorted_cmd;
#[path = "evaluate/teacher_cmd.rs"]
mod teacher_cmd;
#[path = "evaluate/tracks_cmd.rs"]
mod tracks_cmd;

use anyhow::Context;
use clap::Parser;
use eval::vision::{VisionConfig, evaluate_vision, shipped_lens_error};
use eval::vision_report::{self, CalibrationCheck};
use eval::{plots, report, scenarios};
use robot_agent::DetectorKind;
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(about = "Evaluate the fusion core against the seed's method and an oracle")]
struct Args {
    /// Seeds per scenario (0..N); default 20, or 5 with `--vision`; with `--tracks`, the
    /// observation draws per track (default 1).
    #[arg(long)]
    seeds: Option<u64>,
    /// Render the cameras and run the robot agent's pipeline for the observations (default
    /// scenarios: the seed's six). Its generated section is marked
    /// `<!-- evaluate-vision:begin -->` / `<!-- evaluate-vision:end -->`.
    #[arg(long)]
    vision: bool,
    /// With `--vision`: render the ball orange with white patches instead of plain. Its
    /// generated section is marked `<!-- evaluate-vision-patterned:begin -->` / `…:end -->`.
    #[arg(long, requires = "vision")]
    patterned_ball: bool,
    /// With `--vision` or `--photos`, the agent's detector (default: the robot's, as every
    /// command runs it; another's generated section is marked with its name, as
    /// `<!-- evaluate-vision-dissertation:begin -->` / `…:end -->`).
    #[arg(long, value_enum, default_value_t = DetectorKind::default())]
    detector: DetectorKind,
    /// With `--vision`: a model file of `ball-lab train` in place of the shipped one.
    #[arg(long, requires = "vision")]
    model: Option<PathBuf>,
    /// Write the full report as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the markdown table here too.
    #[arg(long)]
    markdown: Option<PathBuf>,
    /// Rewrite the generated section of this markdown file (between
    /// `<!-- evaluate:begin -->` and `<!-- evaluate:end -->`) with the table and targets.
    #[arg(long)]
    doc: Option<PathBuf>,
    /// Directory for the PNG plots.
    #[arg(long, default_value = "out/plots")]
    plots: PathBuf,
    /// Only these scenarios (comma-separated); default all.
    #[arg(long, value_delimiter = ',')]
    scenarios: Vec<String>,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    jobs: usize,
    #[command(flatten)]
    tracks: tracks_cmd::TrackArgs,
    #[command(flatten)]
    labelled: labelled_cmd::LabelledEvalArgs,
    #[command(flatten)]
    teacher: teacher_cmd::TeacherEvalArgs,
    #[command(flatten)]
    sorted: sorted_cmd::SortedEvalArgs,
    /// Score the detector on photos instead: randomised held-out photos on carpets, on
    /// the rendered pitch and on real backgrounds, and real photographs with and without
    /// balls. Its generated section is marked `<!-- evaluate-photos:begin -->` / `…:end -->`.
    #[arg(long, conflicts_with = "vision")]
    photos: bool,
    /// With `--photos`: randomised photos per kind of background.
    #[arg(long, default_value_t = 400, requires = "photos")]
    photo_count: u64,
    /// With `--photos`: the seed of the randomised photos.
    #[arg(long, default_value_t = 2, requires = "photos")]
    photo_seed: u64,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// The scenarios named on the command line, or `default`.
fn scenario_list(args: &Args, default: Vec<&'static str>) -> anyhow::Result<Vec<&'static str>> {
    let all = sim::scenario_names();
    Ok(if args.scenarios.is_empty() {
        default
    } else {
        let mut v = Vec::new();
        for s in &args.scenarios {
            let n =
                all.iter().copied().find(|n| n == s).with_context(|| {
                    format!("unknown scenario {s:?}; known: {}", all.join(", "))
                })?;
            v.push(n);
        }
        v
    })
}

fn run(args: Args) -> anyhow::Result<()> {
    if !args.tracks.tracks.is_empty() {
        let out = tracks_cmd::Outputs {
            seeds: args.seeds.unwrap_or(1),
            jobs: args.jobs,
            json: args.json.as_deref(),
            markdown: args.markdown.as_deref(),
            doc: args.doc.as_deref(),
            plots: &args.plots,
        };
        return tracks_cmd::run(&args.tracks, &out);
    }
    if let (true, Some(dir)) = (args.teacher.teacher, &args.labelled.labelled) {
        return teacher_cmd::run(
            dir,
            args.labelled.labelled_labels.as_deref(),
            &args.labelled.beside,
            &args.teacher,
            args.doc.as_deref(),
            &args.plots,
        );
    }
    if args.sorted.sorted.is_some() {
        return sorted_cmd::run(
            &args.sorted,
            &args.labelled.beside,
            args.doc.as_deref(),
            &args.plots,
        );
    }
    if args.labelled.labelled.is_some() {
        return labelled_cmd::run(&args.labelled, args.doc.as_deref());
    }
    if args.vision {
        return run_vision(&args);
    }
    if args.photos {
        return run_photos(&args);
    }
    let names = scenario_list(&args, sim::scenario_names())?;
    let seeds = args.seeds.unwrap_or(20);
    let cfg = sim::SimConfig::default();
    let started = std::time::Instant::now();
    let results = scenarios::evaluate(&names, seeds, &cfg, args.jobs)?;
    let rep = scenarios::report(&names, seeds, &results);
    let table = report::markdown_table(&rep.scenarios);
    println!("{table}");
    let met = rep.targets.iter().filter(|t| t.met).count();
    println!("Targets met: {met}/{}", rep.targets.len());
    for t in rep.targets.iter().filter(|t| !t.met) {
        println!(
            "  missed: {} — {}: {} (limit {})",
            t.scenario,
            t.target,
            t.value.map_or("n/a".into(), |v| format!("{v:.4}")),
            t.limit
        );
    }
    if let Some(path) = &args.json {
        eval::report::write_json(path, &rep)?;
    }
    if let Some(path) = &args.doc {
        let section = doc_section(&args, &names, &rep, &table, started.elapsed().as_secs_f64());
        report::rewrite_section(path, &section)?;
        eprintln!("updated {}", path.display());
    }
    if let Some(path) = &args.markdown {
        std::fs::write(path, &table).with_context(|| format!("writing {}", path.display()))?;
    }
    let rally = names
        .contains(&"team-rally")
        .then(|| sim::run_scenario("team-rally", 0, &cfg))
        .transpose()?;
    for f in plots::write_all(&args.plots, &results, rally.as_ref())? {
        eprintln!("wrote {f}");
    }
    Ok(())
}

/// The generated part of docs/accuracy.md: how it was produced, the table, the targets.
fn doc_section(
    args: &Args,
    names: &[&str],
    rep: &report::Report,
    table: &str,
    secs: f64,
) -> String {
    let seeds = args.seeds.unwrap_or(20);
    let mut s = format!(
        "Produced by `{}` ({} scenarios × {seeds} seeds, {secs:.0} s on {} worker threads).\n\n{table}\n",
        command(args, names, seeds),
        names.len(),
        args.jobs
    );
    let met = rep.targets.iter().filter(|t| t.met).count();
    s.push_str(&format!(
        "Targets met: {met} of {}.\n\n| scenario | target | measured | met |\n|---|---|---|---|\n",
        rep.targets.len()
    ));
    for t in &rep.targets {
        s.push_str(&format!(
            "| {} | {} | {} | {} |\n",
            t.scenario,
            t.target,
            t.value.map_or("n/a".into(), |v| format!("{v:.3}")),
            if t.met { "yes" } else { "**no**" }
        ));
    }
    s
}

/// The command line that reproduces a run, for the generated sections.
fn command(args: &Args, names: &[&str], seeds: u64) -> String {
    let mut cmd = String::from("cargo run --release -p eval --bin evaluate --");
    if args.vision {
        cmd.push_str(" --vision");
    }
    if args.patterned_ball {
        cmd.push_str(" --patterned-ball");
    }
    if args.detector != DetectorKind::default() {
        cmd.push_str(&format!(" --detector {}", args.detector.name()));
    }
    if let Some(model) = &args.model {
        cmd.push_str(&format!(" --model {}", model.display()));
    }
    cmd.push_str(&format!(" --seeds {seeds}"));
    if let Some(doc) = &args.doc {
        cmd.push_str(&format!(" --doc {}", doc.display()));
    }
    cmd.push_str(&format!(" --plots {}", args.plots.display()));
    if !args.scenarios.is_empty() {
        cmd.push_str(&format!(" --scenarios {}", names.join(",")));
    }
    cmd
}

/// `--vision`: rendered cameras → the agent → the fusion core, scored like the rest.
fn run_vision(args: &Args) -> anyhow::Result<()> {
    let names = scenario_list(args, sim::SEED_SCENARIOS.to_vec())?;
    let seeds = args.seeds.unwrap_or(5);
    let mut vcfg = VisionConfig::default();
    if args.patterned_ball {
        vcfg.camera.ball_look = sim::patterned_ball();
    }
    vcfg.detector = args.detector;
    vcfg.model = args.model.clone();
    let started = std::time::Instant::now();
    let results = evaluate_vision(&names, seeds, &sim::SimConfig::default(), &vcfg, args.jobs)?;
    let grid_step_px = 4.0;
    let (shipped_rms_px, lens) = shipped_lens_error(grid_step_px)?;
    let calibration = CalibrationCheck {
        shipped_rms_px,
        grid_step_px,
        lens,
    };
    let rep = vision_report::report(&names, seeds, vcfg.latency_s, &results, calibration);
    let text = vision_report::markdown(&rep);
    println!("{text}");
    let secs = started.elapsed().as_secs_f64();
    if let Some(path) = &args.json {
        eval::report::write_json(path, &rep)?;
    }
    if let Some(path) = &args.markdown {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &args.doc {
        let section = format!(
            "Produced by `{}` ({} scenarios × {seeds} seeds, {secs:.0} s on {} worker threads; \
             observations reach the fusion core {:.0} ms after capture).\n\n{text}",
            command(args, &names, seeds),
            names.len(),
            args.jobs,
            vcfg.latency_s * 1e3,
        );
        let marker = vision_report::section_name(args.patterned_ball, args.detector);
        let (begin, end) = (
            format!("<!-- {marker}:begin -->"),
            format!("<!-- {marker}:end -->"),
        );
        report::rewrite_section_between(path, &begin, &end, &section)?;
        eprintln!("updated {}", path.display());
    }
    let plot = format!(
        "{}.png",
        vision_report::section_name(args.patterned_ball, args.detector)
            .replace("evaluate-vision", "vision_recall_by_radius")
            .replace('-', "_")
    );
    eprintln!(
        "wrote {}",
        vision_report::write_plot(&args.plots, &plot, &rep)?
    );
    Ok(())
}

/// `--photos`: the detector on randomised held-out photos and real photographs.
fn run_photos(args: &Args) -> anyhow::Result<()> {
    use eval::photo_eval::{self, PhotoEvalConfig};
    let cfg = PhotoEvalConfig {
        count: args.photo_count,
        seed: args.photo_seed,
        backgrounds: "tests/data/backgrounds/heldout".into(),
        real_balls: "tests/data/real-balls".into(),
        profile: sim::PhotoProfile::heldout(),
    };
    let preset = args.detector;
    let chosen = robot_agent::choose_detector(preset, &vision::DetectorConfig::default(), None)?;
    let (detector, classifier) = (&chosen.detector, &chosen.classifier);
    let min_probability = robot_agent::ValidationConfig::default().min_probability;
    let progress = tools::progress::Progress::new(0, "photos scored");
    let results = photo_eval::evaluate_photos(
        &cfg,
        detector,
        classifier.as_ref(),
        min_probability,
        &progress,
    )?;
    progress.finish();
    let text = photo_eval::markdown(&results);
    println!("{text}");
    if let Some(path) = &args.json {
        eval::report::write_json(path, &results)?;
    }
    if let Some(path) = &args.doc {
        let mut cmd = String::from("cargo run --release -p eval --bin evaluate -- --photos");
        if args.photo_count != 400 {
            cmd.push_str(&format!(" --photo-count {}", args.photo_count));
        }
        if args.photo_seed != 2 {
            cmd.push_str(&format!(" --photo-seed {}", args.photo_seed));
        }
        if preset != DetectorKind::default() {
            cmd.push_str(&format!(" --detector {}", preset.name()));
        }
        cmd.push_str(&format!(
            " --doc {} --plots {}",
            path.display(),
            args.plots.display()
        ));
        let section = format!(
            "Produced by `{cmd}` ({} randomised photos per background kind, seed {}; the shipped \
             `{}` detector, no camera model, `min_probability` {min_probability}).\n\n{text}",
            args.photo_count,
            args.photo_seed,
            preset.name(),
        );
        // The default detector's section, or one of its own for another.
        let (begin, end) = if preset == DetectorKind::default() {
            (
                photo_eval::SECTION_BEGIN.to_string(),
                photo_eval::SECTION_END.to_string(),
            )
        } else {
            let name = preset.name();
            (
                format!("<!-- evaluate-photos-{name}:begin -->"),
                format!("<!-- evaluate-photos-{name}:end -->"),
            )
        };
        report::rewrite_section_between(path, &begin, &end, &section)?;
        eprintln!("updated {}", path.display());
    }
    let plot = if preset == DetectorKind::default() {
        "photos_recall_by_width.png".to_string()
    } else {
        format!(
            "photos_recall_by_width_{}.png",
            preset.name().replace('-', "_")
        )
    };
    eprintln!(
        "wrote {}",
        photo_eval::write_plot(&args.plots, &plot, &results)?
    );
    Ok(())
}
