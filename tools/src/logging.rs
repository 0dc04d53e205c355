//! Logging of the tools' long-running programs (`demo`, `sim_robots`, `sim_agent`):
//! tracing to standard error, `RUST_LOG` to choose, Zenoh's own chatter held to errors.

/// Sets up the global subscriber; call once, first thing in `main`.
pub fn init() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=error"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        // Colour codes only for a terminal: a log written to a file or the journal stays plain.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
}
