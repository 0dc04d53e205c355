use super::*;
use proto::{Pitch, WallSide};

fn serve_args(args: &[&str]) -> ServeArgs {
    let argv = ["fusion-server"].iter().chain(args).copied();
    match Cli::try_parse_from(argv).map(|c| c.command) {
        Ok(Command::Serve(a)) => a,
        Ok(Command::Replay(r)) => r.serve,
        other => panic!("{args:?}: {other:?}"),
    }
}

fn config_file(dir: &tempfile::TempDir, text: &str) -> String {
    let path = dir.path().join("fusion-server.toml");
    std::fs::write(&path, text).expect("config written");
    path.to_string_lossy().into_owned()
}

#[test]
fn pitch_flags_override_the_file_which_overrides_the_defaults() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let file = config_file(&dir, "[pitch]\nlength_m = 5.0\nwall_restitution = 0.7\n");
    for command in ["serve", "replay"] {
        let mut args = vec![command, "--config", &file, "--pitch-width-m", "2.8"];
        args.extend(["--walls", "x_min,x_max"]);
        if command == "replay" {
            args.push("match.mcap");
        }
        let (cfg, _) = serve_config(&serve_args(&args))?;
        let want = Pitch {
            length_m: 5.0,
            width_m: 2.8,
            walls: vec![WallSide::XMin, WallSide::XMax],
            wall_restitution: 0.7,
            ..Pitch::default()
        };
        assert_eq!(cfg.engine.fusion.pitch, want, "{command}");
        assert_eq!(cfg.engine.fusion.tracker.motion.restitution, 0.7);
    }
    let (cfg, _) = serve_config(&serve_args(&[
        "serve",
        "--config",
        &file,
        "--wall-restitution",
        "0.4",
    ]))?;
    assert_eq!(cfg.engine.fusion.pitch.wall_restitution, 0.4);
    assert_eq!(cfg.engine.fusion.tracker.motion.restitution, 0.4);
    assert_eq!(cfg.engine.fusion.pitch.length_m, 5.0);
    let (cfg, _) = serve_config(&serve_args(&["serve"]))?;
    assert_eq!(cfg.engine.fusion, crate::estimator::FusionConfig::default());
    Ok(())
}

#[test]
fn a_pitch_that_does_not_work_is_refused_with_its_reason() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let file = config_file(&dir, "[pitch]\nball_radius_m = 0.4\n");
    let err = serve_config(&serve_args(&[
        "serve",
        "--config",
        &file,
        "--pitch-width-m",
        "0.7",
    ]))
    .err()
    .map(|e| format!("{e:#}"));
    assert!(
        err.as_deref()
            .is_some_and(|e| e.contains("does not fit on a 3.9 m × 0.7 m pitch")),
        "{err:?}"
    );
    let bad = config_file(&dir, "[pitch]\nwall_restitution = 1.5\n");
    let err = serve_config(&serve_args(&["serve", "--config", &bad]))
        .err()
        .map(|e| format!("{e:#}"));
    assert!(
        err.as_deref()
            .is_some_and(|e| e.contains("pitch.wall_restitution must be between 0 and 1")),
        "{err:?}"
    );
    let parsed = Cli::try_parse_from(["fusion-server", "serve", "--walls", "north"]);
    let text = parsed.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        text.contains("invalid value 'north' for '--walls <SIDES>'"),
        "{text}"
    );
    Ok(())
}

#[test]
fn a_control_token_must_be_long_enough_to_guess_hard() -> Result<()> {
    let args = [
        "replay",
        "--realtime",
        "--control-token",
        "s3cret-token",
        "m.mcap",
    ];
    let (cfg, _) = serve_config(&serve_args(&args))?;
    assert_eq!(cfg.control_token.as_deref(), Some("s3cret-token"));
    let (cfg, _) = serve_config(&serve_args(&["serve"]))?;
    assert_eq!(cfg.control_token, None, "loopback only by default");
    for bad in ["short", "has space in it"] {
        let err =
            serve_config(&serve_args(&["serve", "--control-token", bad])).expect_err("refused");
        assert!(err.to_string().contains("control token"), "{err}");
    }
    Ok(())
}

#[test]
fn serve_refuses_an_open_network_unless_asked_and_tls_without_a_roster() -> Result<()> {
    let (cfg, _) = serve_config(&serve_args(&["serve"]))?;
    let err = cfg
        .check_security()
        .expect_err("open by default is refused");
    assert!(err.to_string().contains("--open"), "{err}");
    let (cfg, _) = serve_config(&serve_args(&["serve", "--open"]))?;
    cfg.check_security()?;
    assert!(Cli::try_parse_from(["fusion-server", "serve", "--open", "--tls", "k"]).is_err());

    let dir = tempfile::tempdir()?;
    for f in ["ca.pem", "cert.pem", "key.pem"] {
        std::fs::write(dir.path().join(f), "-")?;
    }
    let tls = dir.path().to_string_lossy().into_owned();
    let (cfg, _) = serve_config(&serve_args(&["serve", "--tls", &tls]))?;
    // The default endpoint becomes TLS.
    assert_eq!(cfg.net.listen, ["tls/127.0.0.1:7447"]);
    let err = cfg.check_security().expect_err("no roster");
    assert!(err.to_string().contains("roster"), "{err}");
    let (cfg, _) = serve_config(&serve_args(&[
        "serve",
        "--tls",
        &tls,
        "--roster",
        "miro1",
        "--servers",
        "b",
        "--routers",
        "r1",
    ]))?;
    cfg.check_security()?;
    assert_eq!(
        (cfg.servers.as_slice(), cfg.routers.as_slice()),
        (&["b".to_string()][..], &["r1".to_string()][..])
    );
    // A plain endpoint next to certificates is refused.
    let plain = serve_config(&serve_args(&[
        "serve",
        "--tls",
        &tls,
        "--listen",
        "tcp/0.0.0.0:7447",
    ]));
    assert!(plain.is_err());
    Ok(())
}
