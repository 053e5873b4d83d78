//! `pmacwd explore`: stateright's Explorer (a web page over the model: the states, the actions
//! from each, the properties and the paths to their discoveries) for one configuration of
//! check.yaml under one profile, the model `pmacwd check` checks.
//!
//! The properties carry the names `check` prints (every monitor and state property that
//! applies to the configuration), a state reads card first (`pmacwd_model::show`), and an
//! action's outcome is the concrete event with its reply and the card after it, as `check`
//! prints a path's step. The server is the vendored stateright's (`vendor/stateright`,
//! `checker/explorer.rs`, on tiny_http), given a listener bound here so that a port in use is a
//! plain error and port 0 reports the port chosen.

use crate::common::{console_may_close, load_spec, unusable};
use pmacwd_model::checker::{WatchdogModel, STATES_MAX};
use pmacwd_specs::config::ModelConfig;
use stateright::Model;
use std::io::Write;
use std::net::{SocketAddr, TcpListener};
use std::path::PathBuf;
use std::process::ExitCode;

/// The configuration the Explorer opens without `--configuration`: the watchdog itself.
pub const CONFIGURATION_DEFAULT: &str = "timing";

/// The options of `pmacwd explore`.
#[derive(clap::Args, Debug)]
pub struct ExploreArgs {
    /// The configuration of check.yaml to explore (`pmacwd check` lists them; docs/model.md
    /// says what each explores).
    #[arg(long, value_name = "NAME", default_value = CONFIGURATION_DEFAULT)]
    pub configuration: String,
    /// The profile (reading of the manuals) to explore under (default: the spec's default
    /// profile).
    #[arg(long, value_name = "NAME")]
    pub profile: Option<String>,
    /// Address to serve the Explorer on, HOST:PORT (port 0: one the system chooses, printed).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:3000", value_parser = crate::common::listen_address)]
    pub listen: SocketAddr,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
}

pub fn explore(a: ExploreArgs) -> ExitCode {
    let ExploreArgs { configuration, profile, listen, specs } = a;
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    if !spec.check.configurations.contains_key(&configuration) {
        let names: Vec<&str> = spec.check.configurations.keys().map(String::as_str).collect();
        return unusable(format!(
            "--configuration: no configuration named `{configuration}` in {} (configurations: {})",
            spec.dir.join("check.yaml").display(),
            names.join(", ")
        ));
    }
    let profile = match &profile {
        Some(name) => match spec.profiles.get(name) {
            Some(p) => p,
            None => {
                return unusable(format!("--profile: no profile named `{name}` (profiles: {})", spec.profiles.names()))
            }
        },
        None => spec.profiles.default_profile(),
    };
    let cfg = match ModelConfig::from_spec(&spec, &configuration, &profile) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    // Which profiles `check` runs this configuration under, so that a user exploring another
    // pair knows `check` gives no verdict on it.
    let checked_under: Vec<String> = spec
        .check
        .runs
        .iter()
        .filter(|r| r.configuration == configuration)
        .filter_map(|r| spec.profiles.select(&r.profiles).ok())
        .flatten()
        .map(|p| p.name)
        .collect();
    let listener = match TcpListener::bind(listen) {
        Ok(l) => l,
        Err(e) => return unusable(format!("cannot listen on {listen}: {e}")),
    };
    let address = match listener.local_addr() {
        Ok(a) => a,
        Err(e) => return unusable(format!("cannot listen on {listen}: {e}")),
    };
    let model = WatchdogModel { named_properties: true, ..WatchdogModel::new(cfg) };
    let properties = model.properties().len();
    // The console may be a pipe a script closes once it has read the address.
    console_may_close();
    let mut out = std::io::stdout().lock();
    let _ = writeln!(
        out,
        "pmacwd explore: configuration {configuration} / profile {}, {properties} properties \
         (those that apply, named as `pmacwd check` names them)",
        profile.name
    );
    if checked_under.contains(&profile.name) {
        let _ = writeln!(
            out,
            "  pmacwd check runs this pair: `pmacwd check --configuration {configuration} --profile {}`",
            profile.name
        );
    } else {
        let _ = writeln!(
            out,
            "  pmacwd check does not run this pair (it runs {configuration} under: {}): its verdicts are the Explorer's alone",
            if checked_under.is_empty() { "no profile".to_string() } else { checked_under.join(", ") }
        );
    }
    let _ = writeln!(out, "Explorer at http://{address}/ (JSON: /.status, /.states/FINGERPRINT/...; Ctrl-C to stop)");
    let _ = out.flush();
    drop(out);
    // Explores on demand: the states a user opens, and every state (up to the checker's bound,
    // as `check`) once the page's "run to completion" is pressed.
    match model.checker().target_state_count(STATES_MAX).serve_listener(listener) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => unusable(format!("cannot serve on {address}: {e}")),
    }
}
