//! `robot-agent service --settings FILE`: the agent as the robot's system service starts it,
//! every setting in one TOML file (the package's `/etc/robot-agent/agent.toml`). The file's
//! keys are `run`'s flags (`robot_id` for `--robot-id`), read strictly: an unknown key, a
//! value `run` refuses or a file it names that is not there stops the service before
//! anything starts, with the file and the key in the message and exit status
//! [`SETTINGS_EXIT_CODE`] (which the package's unit does not restart on).

use crate::cli::run_cmd::{self, RunCmdArgs};
use anyhow::Result;
use clap::Parser;
use serde::Deserialize;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The exit status of a service whose settings are wrong (`EX_CONFIG` of sysexits.h).
pub const SETTINGS_EXIT_CODE: u8 = 78;

#[derive(Debug, clap::Args)]
pub struct ServiceArgs {
    /// The settings file.
    #[arg(long, default_value = "/etc/robot-agent/agent.toml")]
    pub settings: PathBuf,
    /// Check the settings and print the `run` command they make, then stop.
    #[arg(long)]
    pub check: bool,
}

/// Settings that keep the service from starting.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {reason}")]
pub struct SettingsError {
    file: PathBuf,
    reason: String,
}

/// The settings file: `run`'s flags as keys.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// This robot's id.
    pub robot_id: String,
    /// Where frames come from (`run --source`).
    pub source: String,
    /// The server's (or a router's) Zenoh endpoints.
    #[serde(default)]
    pub connect: Vec<String>,
    #[serde(default)]
    pub listen: Vec<String>,
    pub mode: Option<String>,
    /// This robot's TLS folder (ca.pem, cert.pem, key.pem).
    pub tls: Option<PathBuf>,
    pub prefix: Option<String>,
    pub calibration: Option<PathBuf>,
    pub calibration_right: Option<PathBuf>,
    #[serde(default)]
    pub rescale_calibration: bool,
    /// Pipeline settings (`run --config`).
    pub config: Option<PathBuf>,
    pub detector: Option<String>,
    pub model: Option<PathBuf>,
    pub ros_master_uri: Option<String>,
    pub ros_key_prefix: Option<String>,
    pub left_topic: Option<String>,
    pub right_topic: Option<String>,
    pub joints_topic: Option<String>,
    pub pose_topic: Option<Vec<String>>,
    pub pose_origin: Option<String>,
    pub status_hz: Option<f64>,
    pub view_hz: Option<f64>,
}

impl Settings {
    /// Reads and checks a settings file.
    pub fn read(file: &Path) -> Result<Settings, SettingsError> {
        let fail = |reason: String| SettingsError {
            file: file.to_path_buf(),
            reason,
        };
        let text = std::fs::read_to_string(file).map_err(|e| fail(format!("cannot read: {e}")))?;
        let settings: Settings = toml::from_str(&text).map_err(|e| fail(e.to_string()))?;
        settings.check().map_err(fail)?;
        Ok(settings)
    }

    /// The keys that name files or folders, with their values.
    fn files(&self) -> [(&'static str, &Option<PathBuf>); 5] {
        [
            ("tls", &self.tls),
            ("calibration", &self.calibration),
            ("calibration_right", &self.calibration_right),
            ("config", &self.config),
            ("model", &self.model),
        ]
    }

    /// What a file can say that `run` would take but the robot cannot work with.
    fn check(&self) -> Result<(), String> {
        if self.robot_id.trim().is_empty() {
            return Err("robot_id is empty: set it to this robot's id (e.g. \"miro1\")".into());
        }
        if self.connect.is_empty() && self.listen.is_empty() {
            return Err(
                "connect is empty: set it to the server's endpoint, e.g. [\"tcp/192.168.1.10:7447\"]"
                    .into(),
            );
        }
        for (key, path) in self.files() {
            if let Some(path) = path
                && !path.exists()
            {
                return Err(format!(
                    "{key} names {}, which does not exist{}",
                    path.display(),
                    match key {
                        "calibration" | "calibration_right" => {
                            " (make it with `ball-lab calibrate`, or remove the key to use the MiRo's nominal lenses)"
                        }
                        "tls" => " (copy the robot's folder from `fusion-server keys` there)",
                        _ => "",
                    }
                ));
            }
        }
        Ok(())
    }

    /// The `run` command line these settings make (without the program's name).
    pub fn run_args(&self) -> Vec<OsString> {
        let mut a: Vec<OsString> = Vec::new();
        let mut flag = |name: &str, value: OsString| {
            a.push(format!("--{name}").into());
            a.push(value);
        };
        flag("robot-id", self.robot_id.clone().into());
        flag("source", self.source.clone().into());
        for e in &self.connect {
            flag("connect", e.into());
        }
        for e in &self.listen {
            flag("listen", e.into());
        }
        let text = [
            ("mode", &self.mode),
            ("prefix", &self.prefix),
            ("detector", &self.detector),
            ("ros-master-uri", &self.ros_master_uri),
            ("ros-key-prefix", &self.ros_key_prefix),
            ("left-topic", &self.left_topic),
            ("right-topic", &self.right_topic),
            ("joints-topic", &self.joints_topic),
            ("pose-origin", &self.pose_origin),
        ];
        for (name, value) in text {
            if let Some(v) = value {
                flag(name, v.into());
            }
        }
        for (key, value) in self.files() {
            if let Some(v) = value {
                flag(&key.replace('_', "-"), v.into());
            }
        }
        if let Some(topics) = &self.pose_topic {
            flag("pose-topic", topics.join(",").into());
        }
        for (name, value) in [("status-hz", self.status_hz), ("view-hz", self.view_hz)] {
            if let Some(v) = value {
                flag(name, v.to_string().into());
            }
        }
        if self.rescale_calibration {
            a.push("--rescale-calibration".into());
        }
        a
    }
}

/// `run`'s own parser, for the command line a settings file makes.
#[derive(Debug, Parser)]
#[command(name = "robot-agent run")]
struct FromSettings {
    #[command(flatten)]
    run: RunCmdArgs,
}

/// Reads the settings into `run`'s arguments, refusing what `run` would refuse.
pub fn parse(file: &Path) -> Result<(RunCmdArgs, Vec<OsString>), SettingsError> {
    let settings = Settings::read(file)?;
    let args = settings.run_args();
    let argv = std::iter::once(OsString::from("robot-agent run")).chain(args.iter().cloned());
    let parsed = FromSettings::try_parse_from(argv).map_err(|e| SettingsError {
        file: file.to_path_buf(),
        reason: format!(
            "{} (keys are `run`'s flags: robot_id for --robot-id)",
            e.render().to_string().trim()
        ),
    })?;
    Ok((parsed.run, args))
}

pub async fn run(args: ServiceArgs) -> Result<()> {
    let (run, argv) = parse(&args.settings)?;
    let shown: Vec<String> = argv
        .iter()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    if args.check {
        println!("robot-agent run {}", shown.join(" "));
        return Ok(());
    }
    tracing::info!(
        "settings {}: robot-agent run {}",
        args.settings.display(),
        shown.join(" ")
    );
    run_cmd::run(run).await
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn write(dir: &Path, text: &str) -> PathBuf {
        let file = dir.join("agent.toml");
        std::fs::write(&file, text).unwrap();
        file
    }

    #[test]
    fn settings_make_runs_command_line() {
        let dir = tempfile::tempdir().unwrap();
        let calib = dir.path().join("left.toml");
        std::fs::write(&calib, "").unwrap();
        let file = write(
            dir.path(),
            &format!(
                "robot_id = \"miro2\"\nsource = \"zenoh:ros1\"\nconnect = [\"tcp/10.0.0.1:7447\"]\n\
                 calibration = {:?}\ndetector = \"net\"\npose_topic = [\"/a\", \"/b\"]\nview_hz = 1.5\n",
                calib
            ),
        );
        let (run, argv) = parse(&file).unwrap();
        assert_eq!(run.run.robot_id, "miro2");
        assert_eq!(run.run.connect, vec!["tcp/10.0.0.1:7447".to_string()]);
        assert_eq!(run.run.calibration.as_deref(), Some(calib.as_path()));
        assert_eq!(run.run.ros.pose_topic, vec!["/a".to_string(), "/b".into()]);
        assert_eq!(run.run.view_hz, 1.5);
        assert!(argv.contains(&OsString::from("--detector")));
    }

    #[test]
    fn wrong_settings_name_the_file_and_the_key() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            (
                "robot_id = \"m\"\nsource = \"zenoh:ros1\"\nconnect = [\"tcp/1.2.3.4:7447\"]\nspeed = 3\n",
                "unknown field `speed`",
            ),
            (
                "robot_id = \"\"\nsource = \"zenoh:ros1\"\nconnect = [\"tcp/1.2.3.4:7447\"]\n",
                "robot_id is empty",
            ),
            (
                "robot_id = \"m\"\nsource = \"zenoh:ros1\"\n",
                "connect is empty",
            ),
            (
                "robot_id = \"m\"\nsource = \"zenoh:ros1\"\nconnect = [\"tcp/1.2.3.4:7447\"]\ncalibration = \"/nowhere/left.toml\"\n",
                "calibration names /nowhere/left.toml, which does not exist",
            ),
            (
                "robot_id = \"m\"\nsource = \"zenoh:ros1\"\nconnect = [\"tcp/1.2.3.4:7447\"]\ndetector = \"best\"\n",
                "invalid value 'best' for '--detector",
            ),
            (
                // A detector name that no longer exists: the key, and the names there are.
                "robot_id = \"m\"\nsource = \"zenoh:ros1\"\nconnect = [\"tcp/1.2.3.4:7447\"]\ndetector = \"config\"\n",
                "invalid value 'config' for '--detector",
            ),
            (
                "robot_id = \"m\"\nsource = \"camera\"\nconnect = [\"tcp/1.2.3.4:7447\"]\n",
                "source \"camera\" is not",
            ),
        ];
        for (text, expected) in cases {
            let file = write(dir.path(), text);
            let e = parse(&file).unwrap_err().to_string();
            assert!(e.contains(expected), "{e:?} should say {expected:?}");
            assert!(e.starts_with(&file.display().to_string()), "{e}");
        }
        let missing = parse(&dir.path().join("none.toml"))
            .unwrap_err()
            .to_string();
        assert!(missing.contains("cannot read"), "{missing}");
    }
}
