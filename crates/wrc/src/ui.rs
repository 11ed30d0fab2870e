//! `wrc ui`: the web GUI's server, bridge and the editor's compiler (crate `wrc-ui`), started
//! by `wrc up` or alone on another PC with `--controller HOST:PORT`; stopped by SIGINT or
//! SIGTERM.

use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use wrc_config::Config;
use wrc_ui::{Endpoint, Options, Ui};

/// Arguments of `wrc ui`.
#[derive(Debug, Args)]
pub struct UiArgs {
    /// The controller: its Unix socket path, or HOST:PORT of its host protocol (TCP).
    #[arg(long, value_name = "ADDR", default_value = "/tmp/wrc/wrc.sock")]
    controller: String,
    /// Address to serve the GUI on; anything but loopback needs --token.
    #[arg(long, value_name = "IP", default_value = "127.0.0.1")]
    listen: IpAddr,
    /// Port to serve the GUI on.
    #[arg(long, value_name = "PORT", default_value_t = 8080)]
    ui_port: u16,
    /// Receive the controller's simulator datagrams on this UDP address.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7200")]
    sim_addr: SocketAddr,
    /// Do not receive simulator datagrams (the 3D view and plots stay still).
    #[arg(long)]
    no_sim: bool,
    /// Secret every browser must present (open http://HOST:PORT/?token=SECRET); required
    /// when --listen is not a loopback address. Also read from WRC_UI_TOKEN.
    #[arg(
        long,
        value_name = "SECRET",
        env = "WRC_UI_TOKEN",
        hide_env_values = true
    )]
    token: Option<String>,
    /// The controller's control token file (its `[host] token_file`): each browser's TCP
    /// connection to the controller presents it with AUTH, so the GUI may command a
    /// controller that asks for it.
    #[arg(long, value_name = "FILE")]
    controller_token_file: Option<PathBuf>,
    /// Serve the app from this folder (a `web/dist` build) instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    web_dir: Option<PathBuf>,
    /// Robot configuration (TOML) the editor's programs are compiled for: the controller's
    /// (`wrc up` passes its own); default: the embedded paper robot.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// The controller's program folder (`STATE_DIR/programs`; `wrc up` passes its own): the
    /// editor's compiler reads the libraries, called programs and points files it does not
    /// send from there.
    #[arg(long, value_name = "DIR")]
    programs: Option<PathBuf>,
}

/// Run `wrc ui` until SIGINT or SIGTERM.
pub fn run(args: UiArgs) -> anyhow::Result<ExitCode> {
    let mut signals = crate::up::termination_signals()?;
    let listen = SocketAddr::new(args.listen, args.ui_port);
    let controller = Endpoint::parse(&args.controller)?;
    let config = Config::load(args.config.as_deref())?;
    let controller_token = match &args.controller_token_file {
        Some(file) => Some(
            wrc_controller::host_access::read_token(file)?
                .as_str()
                .to_string(),
        ),
        None => None,
    };
    let ui = Ui::start(Options {
        controller_token,
        listen,
        controller: controller.clone(),
        sim_addr: (!args.no_sim).then_some(args.sim_addr),
        token: args.token.clone(),
        web_dir: args.web_dir.clone(),
        robot: config.robot.clone(),
        programs: args.programs.clone(),
    })
    .context("the GUI could not start")?;
    let addr = ui.local_addr();
    let host = if addr.ip().is_unspecified() {
        "HOST".to_string()
    } else {
        addr.ip().to_string()
    };
    let query = if args.token.is_some() {
        "/?token=…"
    } else {
        ""
    };
    println!("wrc ui: GUI on http://{host}:{}{query}", addr.port());
    println!("wrc ui: app {}", ui.assets().describe());
    println!("wrc ui: controller {controller}");
    match &args.programs {
        Some(dir) => println!(
            "wrc ui: the editor compiles for {} ({}), with the programs in {}",
            config.robot.name,
            config.source,
            dir.display()
        ),
        None => println!(
            "wrc ui: the editor compiles for {} ({})",
            config.robot.name, config.source
        ),
    }
    match ui.sim_addr() {
        Some(a) => println!("wrc ui: simulator datagrams from udp {a}"),
        None => println!("wrc ui: no simulator stream (--no-sim)"),
    }
    use std::io::Write;
    let _ = std::io::stdout().flush();
    let _ = signals.forever().next();
    ui.stop();
    println!("wrc ui: stopped");
    Ok(ExitCode::SUCCESS)
}
