//! `pmacwd serve`: the emulator on the card's Ethernet protocol.

use crate::common::{create_capture, listen_address, model_config, unusable};
use pmacwd_bridge::core_config;
use pmacwd_emulator::card::{servo_rate, Card, Clock, Identity, SAVED_DEFAULT};
use pmacwd_emulator::server::{ServeOptions, Server, CONTROL_IDLE_TIMEOUT_DEFAULT_SECONDS};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// The most `--clients-max` admits (a test of `record` ran 100,000 behind it).
const CLIENTS_MAX_MAX: usize = 100_000;
/// The longest idle timeout, a year in seconds: longer is `0` (never) in all but name.
const TIMEOUT_SECONDS_MAX: u64 = 365 * 24 * 3600;
const TIMEOUT_WHY: &str = " seconds (0: never; at most a year)";

/// Turbo PMAC emulator on the Ethernet protocol, backed by the compact core.
#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// Address for host programs, HOST:PORT, HOST an address or a name (the card's port is 1025).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:1025", value_parser = listen_address)]
    pub listen: SocketAddr,
    /// Address of the control interface (load, faults, INIT/, power; docs/emulator.md), HOST:PORT.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:1026", value_parser = listen_address)]
    pub control: SocketAddr,
    /// Run without a control interface.
    #[arg(long)]
    pub no_control: bool,
    /// The check.yaml configuration to emulate: CPU costs, hardware delay, saved I8/I40/I41
    /// (`emulated`: i40-zero's card with no background PLC, a background cycle every servo
    /// cycle).
    #[arg(long, value_name = "NAME", default_value = pmacwd_emulator::card::DEFAULT_CONFIGURATION)]
    pub configuration: String,
    /// The profile (reading of the manuals) to emulate (default: the spec's default profile).
    #[arg(long, value_name = "NAME")]
    pub profile: Option<String>,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
    /// Servo interrupt rate, 1..100000 Hz (the servo clock range of specs/scheduling.yaml;
    /// default: the configuration's; 100 kHz is above any servo clock a real card sustains,
    /// docs/emulator.md "Limits").
    #[arg(long, allow_negative_numbers = true, value_name = "HZ", value_parser = crate::common::servo_hz)]
    pub servo_hz: Option<u32>,
    /// Time moves only by `step` and `servo` on the control interface (for tests).
    #[arg(long)]
    pub virtual_time: bool,
    /// An I-variable value saved in flash, restored by every reset: `I3=1`, `I40=100`
    /// (repeatable; defaults I3=2 and I6=1, the framing host drivers expect).
    #[arg(long = "saved", value_name = "IN=V")]
    pub saved: Vec<String>,
    /// The CPU option `???` reports in its bits 21 (SRM p.289): DSP56303, DSP56309, DSP56311
    /// or DSP56321 (default: the configuration's `processor`, DSP56303 when it names none).
    #[arg(long, value_name = "CPU")]
    pub processor: Option<String>,
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
    #[arg(long, allow_negative_numbers = true, value_name = "N", default_value_t = 128, value_parser = crate::common::ranged(1usize, CLIENTS_MAX_MAX, " (each open connection has its thread)"))]
    pub clients_max: usize,
    /// Close a host connection silent this long (0: never, as a card never closes one; at
    /// --clients-max the one idle longest makes room for a newcomer).
    #[arg(long, allow_negative_numbers = true, value_name = "SECONDS", default_value_t = 0, value_parser = crate::common::ranged(0u64, TIMEOUT_SECONDS_MAX, TIMEOUT_WHY))]
    pub idle_timeout: u64,
    /// Close a control connection silent this long (0: never); when 16 are open, the one idle
    /// longest is closed for a newcomer.
    #[arg(long, allow_negative_numbers = true, value_name = "SECONDS", default_value_t = CONTROL_IDLE_TIMEOUT_DEFAULT_SECONDS, value_parser = crate::common::ranged(0u64, TIMEOUT_SECONDS_MAX, TIMEOUT_WHY))]
    pub control_idle_timeout: u64,
    /// Log connections, their ends and each protocol error to standard error (without it,
    /// protocol errors are summed up on one line at most once a minute).
    #[arg(long)]
    pub verbose: bool,
    /// Hidden, for testing testers (`pmacwd probe`'s tests): answer with one deliberately
    /// broken behaviour (emulator/src/fault.rs).
    #[arg(long, hide = true, value_name = "NAME", value_parser = ["x25-not-latched", "i41-ignored", "bit22-not-sticky", "never-trips", "status-constant"])]
    pub fault: Option<String>,
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
            3 | 6 => {
                // The framing variables, as a host write of them is checked (MODEL).
                range(pmacwd_emulator::framing::FRAMING_VALUE_MAX)?;
                saved.retain(|(k, _)| *k != n);
                saved.push((n, v));
            }
            _ => {
                saved.retain(|(k, _)| *k != n);
                saved.push((n, v));
            }
        }
    }
    Ok(saved)
}

pub fn serve(a: ServeArgs) -> ExitCode {
    let model = match model_config(&a.specs, &a.configuration, a.profile.as_deref()) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    let mut cfg = core_config(&model);
    // The card's X:$0 counts 24 bits (the model keeps it only where a configuration asks).
    cfg.servo_counter_mask = 0xFF_FFFF;
    if let Some(p) = &a.processor {
        match pmacwd_specs::check::Processor::parse(p) {
            Ok(p) => cfg.processor = pmacwd_bridge::core_processor(p),
            Err(e) => return unusable(format!("--processor {e}")),
        }
    }
    let saved = match saved_values(&a.saved, &mut cfg) {
        Ok(s) => s,
        Err(e) => return unusable(e),
    };
    let servo_hz = match servo_rate(a.servo_hz, &model) {
        Ok(hz) => hz,
        Err(e) => return unusable(e),
    };
    let clock = if a.virtual_time { Clock::Virtual } else { Clock::Wall { start: Instant::now(), servo_hz } };
    let identity = Identity { version: a.version_text.clone(), card_id: a.card_id.clone() };
    let mut card = Card::power_on(cfg, &saved, clock, identity);
    if let Some(name) = &a.fault {
        match pmacwd_emulator::fault::Fault::parse(name) {
            Ok(f) => card.inject_fault(f),
            Err(e) => return unusable(format!("--fault: {e}")),
        }
    }
    // The card's console: a trip, INIT/, power, `$$$` and the recovery, one line each.
    card.on_console(Box::new(|line| {
        pmacwd_emulator::bounded::to_stdout(format_args!("pmacwd serve: {line}"));
    }));
    if let Some(path) = &a.record {
        let description = format!(
            "recorded by pmacwd serve ({}, profile {}, {servo_hz} Hz{})",
            a.configuration,
            model.profile.name,
            if a.virtual_time { ", virtual time" } else { "" }
        );
        match create_capture(path, &description, &a.configuration, pmacwd_emulator::capture::Timing::Exact) {
            Ok(c) => {
                if let Err(e) = card.record(c) {
                    return unusable(format!("{}: cannot start the capture's writer: {e}", path.display()));
                }
            }
            Err(e) => return unusable(e),
        }
    }
    let options = ServeOptions {
        listen: a.listen,
        control: (!a.no_control).then_some(a.control),
        clients_max: a.clients_max,
        idle_timeout: (a.idle_timeout > 0).then(|| Duration::from_secs(a.idle_timeout)),
        control_idle_timeout: (a.control_idle_timeout > 0).then(|| Duration::from_secs(a.control_idle_timeout)),
        verbose: a.verbose,
        thread_stack_bytes: None,
    };
    let server = match Server::start(card, options) {
        Ok(s) => s,
        Err(e) => return unusable(format!("cannot listen: {e}")),
    };
    pmacwd_emulator::bounded::to_stdout(format_args!(
        "pmacwd serve: Turbo PMAC emulator on {} ({}), configuration {}, profile {}, {}{}",
        server.local_addr,
        match server.control_addr {
            Some(c) => format!("control on {c}"),
            None => "no control interface".into(),
        },
        a.configuration,
        model.profile.name,
        if a.virtual_time { "virtual time".to_string() } else { format!("{servo_hz} Hz servo clock") },
        a.fault.as_ref().map(|f| format!(", BROKEN on purpose: {f}")).unwrap_or_default()
    ));
    if let Some(p) = &a.record {
        pmacwd_emulator::bounded::to_stdout(format_args!("recording to {}", p.display()));
    }
    crate::common::console_may_close();
    // Nothing else ends a server: it runs until SIGINT or SIGTERM, then stops in order.
    crate::interrupt::install();
    let signal = crate::interrupt::wait_for_stop(|| false).unwrap_or("a signal");
    let connections = server.stats().connections.load(std::sync::atomic::Ordering::Relaxed);
    let (steps, left_over) = server.stop_then(|card| card.finish_recording_counted());
    for note in left_over {
        pmacwd_emulator::bounded::to_stderr(format_args!(
            "pmacwd serve: left over at the end of the recording: {note}"
        ));
    }
    pmacwd_emulator::bounded::to_stdout(format_args!(
        "pmacwd serve: stopped by {signal} after {}",
        crate::common::plural(connections, "host connection", "host connections")
    ));
    if let Some(p) = &a.record {
        pmacwd_emulator::bounded::to_stdout(format_args!(
            "recorded {} in {}",
            crate::common::plural(steps, "step", "steps"),
            p.display()
        ));
    }
    ExitCode::SUCCESS
}
