//! The `serve` and `record` subcommands of `pmacwd`.

use super::capture::CaptureWriter;
use super::card::{Card, Clock, Identity, SAVED_DEFAULT};
use super::proxy::{Proxy, RecordOptions, Recorder};
use super::server::{ServeOptions, Server};
use pmacwd_bridge::core_config;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::Spec;
use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Turbo PMAC emulator on the Ethernet protocol, backed by the compact core.
#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// Address for host programs (the card's port is 1025).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:1025")]
    pub listen: SocketAddr,
    /// Address of the control interface (load, faults, INIT/, power; docs/emulator.md).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:1026")]
    pub control: SocketAddr,
    /// Run without a control interface.
    #[arg(long)]
    pub no_control: bool,
    /// The check.yaml configuration to emulate: CPU costs, hardware delay, saved I8/I40/I41.
    #[arg(long, value_name = "NAME", default_value = "i40-zero")]
    pub configuration: String,
    /// The profile (reading of the manuals) to emulate (default: the spec's default profile).
    #[arg(long, value_name = "NAME")]
    pub profile: Option<String>,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
    /// Servo interrupt rate (default: the configuration's).
    #[arg(long, value_name = "HZ")]
    pub servo_hz: Option<u32>,
    /// Time moves only by `step` and `servo` on the control interface (for tests).
    #[arg(long)]
    pub virtual_time: bool,
    /// An I-variable value saved in flash, restored by every reset: `I3=1`, `I40=100`
    /// (repeatable; defaults I3=2 and I6=1, the framing host drivers expect).
    #[arg(long = "saved", value_name = "IN=V")]
    pub saved: Vec<String>,
    /// What `ver` answers.
    #[arg(long, value_name = "TEXT", default_value = "1.947")]
    pub version_text: String,
    /// What `cid` answers (603382: Geo Brick).
    #[arg(long, value_name = "TEXT", default_value = "603382")]
    pub card_id: String,
    /// Write every session with this card as a capture (trace format, JSON Lines).
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Host connections open at once; beyond it the one idle longest is closed.
    #[arg(long, value_name = "N", default_value_t = 128)]
    pub clients_max: usize,
    /// Close a host connection silent this long (0: never).
    #[arg(long, value_name = "SECONDS", default_value_t = 600)]
    pub idle_timeout: u64,
    /// Log connections and their ends to standard error.
    #[arg(long)]
    pub verbose: bool,
}

/// Transparent proxy that writes host sessions with a card as a capture.
#[derive(clap::Args, Debug)]
pub struct RecordArgs {
    /// Address the host program connects to instead of the card.
    #[arg(long, value_name = "ADDR")]
    pub listen: SocketAddr,
    /// The card (or emulator): HOST:PORT.
    #[arg(long, value_name = "ADDR")]
    pub target: String,
    /// The capture to write (trace format, JSON Lines; replay it with `pmacwd replay`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// The check.yaml configuration the capture names (and whose servo rate times it).
    #[arg(long, value_name = "NAME", default_value = "i40-zero")]
    pub configuration: String,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
    /// The card's servo rate (default: the configuration's).
    #[arg(long, value_name = "HZ")]
    pub servo_hz: Option<u32>,
    /// Also proxy an emulator's control interface: listen here ...
    #[arg(long, value_name = "ADDR", requires = "control_target")]
    pub control_listen: Option<SocketAddr>,
    /// ... and forward to this one; its events go into the capture.
    #[arg(long, value_name = "ADDR", requires = "control_listen")]
    pub control_target: Option<String>,
    /// Time only from the proxied control interface's `step` commands (an emulator in
    /// virtual time): exact to the servo cycle.
    #[arg(long, requires = "control_target")]
    pub virtual_time: bool,
    /// No reply byte for this long counts as silence (a tripped card).
    #[arg(long, value_name = "MS", default_value_t = 1000)]
    pub silence_ms: u64,
    /// Stop after this many host sessions have ended (default: run until killed; every
    /// exchange is on disk as soon as it completes).
    #[arg(long, value_name = "N")]
    pub sessions: Option<u64>,
    /// Log sessions to standard error.
    #[arg(long)]
    pub verbose: bool,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("pmacwd: {msg}");
    ExitCode::from(2)
}

fn model_config(specs: &Option<PathBuf>, configuration: &str, profile: Option<&str>) -> Result<ModelConfig, String> {
    let spec = match specs {
        Some(dir) => Spec::load_dir(dir),
        None => Spec::embedded(),
    }
    .map_err(|e| e.to_string())?;
    let profile = match profile {
        Some(name) => spec.profiles.get(name).ok_or_else(|| {
            format!(
                "no profile named `{name}` (profiles: {})",
                spec.profiles.profiles.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })?,
        None => spec.profiles.default_profile(),
    };
    ModelConfig::from_spec(&spec, configuration, &profile).map_err(|e| e.to_string())
}

/// `I3=2` and the like; I8, I40 and I41 go to the core's saved values, within their ranges.
fn saved_values(texts: &[String], cfg: &mut pmacwd_core::Config) -> Result<Vec<(u16, i64)>, String> {
    let mut saved: Vec<(u16, i64)> = SAVED_DEFAULT.to_vec();
    for t in texts {
        let bad = || format!("--saved `{t}`: expected IN=V, e.g. I3=2");
        let (n, v) = t.split_once('=').ok_or_else(bad)?;
        let n = n.trim().strip_prefix(['I', 'i']).ok_or_else(bad)?;
        let n: u16 = n.parse().map_err(|_| bad())?;
        if n > pmacwd_core::I_VARIABLE_MAX {
            return Err(format!("--saved `{t}`: Turbo PMAC has I0..I{}", pmacwd_core::I_VARIABLE_MAX));
        }
        let v: i64 = v.trim().parse().map_err(|_| bad())?;
        let range = |max: i64| {
            if (0..=max).contains(&v) {
                Ok(())
            } else {
                Err(format!("--saved `{t}`: I{n} ranges 0..{max}"))
            }
        };
        match n {
            8 => {
                range(pmacwd_core::I8_MAX)?;
                cfg.saved_i8 = v as u8;
            }
            40 => {
                range(pmacwd_core::I40_MAX)?;
                cfg.saved_i40 = v as u16;
            }
            41 => {
                range(pmacwd_core::I41_MAX)?;
                cfg.saved_i41 = v as u8;
            }
            _ => {
                saved.retain(|(k, _)| *k != n);
                saved.push((n, v));
            }
        }
    }
    Ok(saved)
}

fn create_capture(
    path: &Path,
    description: &str,
    configuration: &str,
    timing: super::capture::Timing,
) -> Result<CaptureWriter<Box<dyn Write + Send>>, String> {
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let out: Box<dyn Write + Send> = Box::new(std::io::BufWriter::new(file));
    CaptureWriter::new(out, description, configuration, timing).map_err(|e| format!("{}: {e}", path.display()))
}

pub fn serve(a: ServeArgs) -> ExitCode {
    let model = match model_config(&a.specs, &a.configuration, a.profile.as_deref()) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    let mut cfg = core_config(&model);
    // The card's X:$0 counts 24 bits (the model keeps it only where a configuration asks).
    cfg.servo_counter_mask = 0xFF_FFFF;
    let saved = match saved_values(&a.saved, &mut cfg) {
        Ok(s) => s,
        Err(e) => return unusable(e),
    };
    let servo_hz = a.servo_hz.unwrap_or(model.servo_hz);
    if servo_hz == 0 {
        return unusable("--servo-hz must be at least 1");
    }
    let clock = if a.virtual_time { Clock::Virtual } else { Clock::Wall { start: Instant::now(), servo_hz } };
    let identity = Identity { version: a.version_text.clone(), card_id: a.card_id.clone() };
    let mut card = Card::power_on(cfg, &saved, clock, identity);
    if let Some(path) = &a.record {
        let description = format!(
            "recorded by pmacwd serve ({}, profile {}, {servo_hz} Hz{})",
            a.configuration,
            model.profile.name,
            if a.virtual_time { ", virtual time" } else { "" }
        );
        match create_capture(path, &description, &a.configuration, super::capture::Timing::Exact) {
            Ok(c) => card.record(c),
            Err(e) => return unusable(e),
        }
    }
    let options = ServeOptions {
        listen: a.listen,
        control: (!a.no_control).then_some(a.control),
        clients_max: a.clients_max,
        idle_timeout: (a.idle_timeout > 0).then(|| Duration::from_secs(a.idle_timeout)),
        verbose: a.verbose,
    };
    let server = match Server::start(card, options) {
        Ok(s) => s,
        Err(e) => return unusable(format!("cannot listen: {e}")),
    };
    println!(
        "pmacwd serve: Turbo PMAC emulator on {} ({}), configuration {}, profile {}, {}",
        server.local_addr,
        match server.control_addr {
            Some(c) => format!("control on {c}"),
            None => "no control interface".into(),
        },
        a.configuration,
        model.profile.name,
        if a.virtual_time { "virtual time".to_string() } else { format!("{servo_hz} Hz servo clock") }
    );
    if let Some(p) = &a.record {
        println!("recording to {}", p.display());
    }
    let _ = std::io::stdout().flush();
    server.wait();
    ExitCode::SUCCESS
}

pub fn record(a: RecordArgs) -> ExitCode {
    let model = match model_config(&a.specs, &a.configuration, None) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    let servo_hz = a.servo_hz.unwrap_or(model.servo_hz);
    if servo_hz == 0 {
        return unusable("--servo-hz must be at least 1");
    }
    let timing = Recorder::timing(servo_hz, a.virtual_time);
    let description = format!(
        "recorded by pmacwd record from {} ({})",
        a.target,
        if a.virtual_time { "virtual time".to_string() } else { format!("host clock at {servo_hz} Hz") }
    );
    let capture = match create_capture(&a.out, &description, &a.configuration, timing) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    let options = RecordOptions {
        listen: a.listen,
        target: a.target.clone(),
        control: a.control_listen.zip(a.control_target.clone()),
        servo_hz,
        virtual_time: a.virtual_time,
        silence: Duration::from_millis(a.silence_ms.max(1)),
        sessions: a.sessions,
        verbose: a.verbose,
    };
    let proxy = match Proxy::start(Recorder::new(capture, servo_hz, a.virtual_time), options) {
        Ok(p) => p,
        Err(e) => return unusable(format!("cannot listen: {e}")),
    };
    println!(
        "pmacwd record: {} -> {}{}, writing {}",
        proxy.local_addr,
        a.target,
        match (proxy.control_addr, &a.control_target) {
            (Some(l), Some(t)) => format!(" (control {l} -> {t})"),
            _ => String::new(),
        },
        a.out.display()
    );
    let _ = std::io::stdout().flush();
    match proxy.wait() {
        Ok((exchanges, steps, notes)) => {
            for n in notes {
                eprintln!("pmacwd record: left over at the end: {n}");
            }
            println!("recorded {exchanges} exchanges as {steps} steps in {}", a.out.display());
            ExitCode::SUCCESS
        }
        Err(e) => unusable(format!("{}: {e}", a.out.display())),
    }
}
