//! `replay`: match logs re-fused offline, or played back over Zenoh and HTTP as if live.

use crate::cli::ReplayArgs;
use crate::matchlog::RecorderSink;
use crate::matchlog::read::{LogMessage, read_logs};
use crate::matchlog::record::RecorderConfig;
use crate::matchlog::record::remove_earlier;
use crate::matchlog::replay::{
    ReplayOptions, ReplayOutputs, StatesCsv, replay, summary_json, summary_text,
};
use crate::shell::args::{bind_http, serve_config, shutdown_signal};
use crate::shell::net::NetConfig;
use crate::shell::replay_control::ReplayControl;
use crate::shell::replay_live::{Deliver, PlayConfig, play};
use crate::shell::serve;
use anyhow::{Context, Result};
use futures_util::future::BoxFuture;
use proto::{KeySpace, Stamp};
use std::collections::BTreeSet;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::sync::Arc;
use std::time::Instant;

/// A one-line progress bar on a terminal; quarter marks otherwise.
fn progress_bar(label: &'static str) -> impl FnMut(usize, usize) {
    let tty = std::io::stderr().is_terminal();
    let mut last_quarter = usize::MAX;
    move |done, total| {
        let total = total.max(1);
        let pct = done * 100 / total;
        if tty {
            let filled = pct * 30 / 100;
            eprint!(
                "\r{label} [{}{}] {pct:3}% ({done}/{total})",
                "#".repeat(filled),
                " ".repeat(30 - filled)
            );
            if done >= total {
                eprintln!();
            }
            let _ = std::io::stderr().flush();
        } else if pct / 25 != last_quarter {
            last_quarter = pct / 25;
            eprintln!("{label}: {pct}% ({done}/{total})");
        }
    }
}

fn read(files: &[std::path::PathBuf]) -> Result<Vec<LogMessage>> {
    let log = read_logs(files)?;
    if !log.complete {
        let ends = match (log.messages.first(), log.messages.last()) {
            (Some(first), Some(last)) => format!(
                "its last message is {:.1} s after its first; ",
                last.log_time.secs_since(first.log_time)
            ),
            _ => String::new(),
        };
        eprintln!(
            "warning: log incomplete ({}): the server writing it stopped without closing it \
             (killed, or its disk failed); {ends}replaying the {} messages it holds",
            log.problem.as_deref().unwrap_or("no footer"),
            log.messages.len()
        );
    }
    Ok(log.messages)
}

/// Where the states go as CSV, when asked.
fn states_csv(a: &ReplayArgs, start: Stamp) -> Result<Option<StatesCsv<BufWriter<File>>>> {
    a.states_csv
        .as_ref()
        .map(|path| {
            let file = File::create(path)
                .with_context(|| format!("creating the states file {}", path.display()))?;
            Ok(StatesCsv::new(BufWriter::new(file), start))
        })
        .transpose()
}

pub fn offline(a: ReplayArgs) -> Result<()> {
    let (cfg, _) = serve_config(&a.serve)?;
    let messages = read(&a.files)?;
    let opts = ReplayOptions {
        engine: cfg.engine.clone(),
        prefix: cfg.prefix.clone(),
        state_rate_hz: cfg.state_rate_hz,
        at: a.at.clone(),
        align: a.align,
        until: a.until,
        // A new log gets the match drawn for Foxglove (an older log's scene is replaced).
        scene: !a.no_log,
    };
    let start = messages.first().map(|m| m.log_time).unwrap_or(Stamp(0));
    let log = if a.no_log {
        None
    } else {
        let stem = a.files[0]
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "log".into());
        let mut r = RecorderConfig::new(&a.out);
        r.file_prefix = format!("replay-{stem}");
        remove_earlier(&a.out, &r.file_prefix)?;
        Some(RecorderSink::create(r, start)?)
    };
    let mut sinks = (log, states_csv(&a, start)?);
    let t0 = Instant::now();
    let report = replay(&messages, &opts, &mut sinks, &mut progress_bar("replay"))?;
    let (log, csv) = sinks;
    let mut out = ReplayOutputs::default();
    if let Some(log) = log {
        let files = log.finish()?.files;
        out.log_files = files.iter().map(|f| f.display().to_string()).collect();
    }
    if let (Some(csv), Some(path)) = (csv, &a.states_csv) {
        csv.finish()
            .with_context(|| format!("writing the states file {}", path.display()))?;
        out.states_csv = Some(path.display().to_string());
    }
    let wall_s = t0.elapsed().as_secs_f64();
    if a.json {
        println!("{}", summary_json(&report, wall_s, &out));
    } else {
        print!("{}", summary_text(&report, wall_s));
        for f in &out.log_files {
            println!("replayed log: {f}");
        }
        if let Some(p) = &out.states_csv {
            println!("states csv: {p}");
        }
    }
    Ok(())
}

/// Re-sends recorded inputs over Zenoh, declaring each robot's liveliness token when the
/// robot first appears.
struct ZenohDeliver {
    session: zenoh::Session,
    keys: KeySpace,
    seen: BTreeSet<String>,
    tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

impl Deliver for ZenohDeliver {
    fn deliver<'a>(&'a mut self, m: &'a LogMessage) -> BoxFuture<'a, ()> {
        Box::pin(async move {
            if let Some(id) = self.keys.robot_id_of(&m.topic)
                && self.seen.insert(id.to_string())
            {
                match self.keys.robot_liveliness(id) {
                    Ok(key) => match self.session.liveliness().declare_token(key).await {
                        Ok(t) => self.tokens.push(t),
                        Err(e) => tracing::warn!("declaring robot {id}'s token: {e}"),
                    },
                    Err(e) => tracing::warn!("robot {id}: {e}"),
                }
            }
            if let Err(e) = self.session.put(m.topic.as_str(), m.data.clone()).await {
                tracing::warn!("re-publishing {}: {e}", m.topic);
            }
        })
    }
}

/// Plays the log back in (scaled) real time: a server whose clock runs through the match,
/// fed over Zenoh by a publisher that re-sends each recorded message when it was received.
/// Pause, speed and seeks come from the control endpoints (the coach's page).
pub async fn realtime(a: ReplayArgs) -> Result<()> {
    anyhow::ensure!(
        a.at.is_empty() && a.align.is_none() && a.until.is_none() && a.states_csv.is_none(),
        "--at, --align, --until and --states-csv are for offline replay, not --realtime"
    );
    let (mut cfg, _) = serve_config(&a.serve)?;
    if cfg.net.listen.is_empty() {
        cfg.net.listen = vec!["tcp/127.0.0.1:7447".into()];
    }
    let mut messages = read(&a.files)?;
    // A log keeps a view's image apart from its metadata: made whole to be re-sent.
    crate::camera_views::images::rejoin(&mut messages);
    let (Some(first), Some(last)) = (messages.first(), messages.last()) else {
        anyhow::bail!("the log holds no messages");
    };
    let control = Arc::new(
        ReplayControl::new(first.log_time, last.log_time, a.speed)
            .map_err(|e| anyhow::anyhow!("--speed: {e}"))?,
    );
    let live = serve::shared(&cfg, control.clock.clone(), None)?;
    live.set_replay(control.clone());
    let http = bind_http(&cfg.http).await?;
    println!("http://{}/", http.local_addr()?);
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let mut server_stop = stop_rx;
    let server = tokio::spawn(serve::serve(cfg.clone(), live.clone(), http, async move {
        let _ = server_stop.wait_for(|s| *s).await;
    }));
    let session = NetConfig::connecting(&cfg.net.listen[0]).open().await?;
    let keys = KeySpace::new(&cfg.prefix)?;
    let mut deliver = ZenohDeliver {
        session: session.clone(),
        keys: keys.clone(),
        seen: BTreeSet::new(),
        tokens: Vec::new(),
    };
    let play_cfg = PlayConfig {
        engine: cfg.engine.clone(),
        keys,
        stay: a.stay,
    };
    let mut bar = progress_bar("replay");
    play(
        live,
        control,
        &messages,
        play_cfg,
        &mut deliver,
        &mut bar,
        shutdown_signal(),
    )
    .await;
    drop(deliver);
    let _ = stop_tx.send(true);
    server.await??;
    let _ = session.close().await;
    Ok(())
}
