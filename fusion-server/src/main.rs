//! `fusion-server`: the team ball server, replay of match logs, and the keys of a secured
//! network. The command line lives in the library ([`fusion_server::main`]).

fn main() -> anyhow::Result<()> {
    fusion_server::main()
}
