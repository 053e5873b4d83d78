//! `pmacwd record`: a transparent proxy that writes host sessions as a capture.

use crate::common::{create_capture, listen_address, model_config, unusable};
use pmacwd_emulator::bounded::{to_stderr, to_stdout};
use pmacwd_emulator::proxy::{Proxy, RecordOptions, Recorder};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Transparent proxy that writes host sessions with a card as a capture.
#[derive(clap::Args, Debug)]
pub struct RecordArgs {
    /// Address the host program connects to instead of the card, HOST:PORT (HOST an address
    /// or a name); at most 128 sessions are open at once, a newcomer closing the one idle
    /// longest (16 on --control-listen).
    #[arg(long, value_name = "ADDR", value_parser = listen_address)]
    pub listen: SocketAddr,
    /// The card (or emulator): HOST:PORT.
    #[arg(long, value_name = "ADDR")]
    pub target: String,
    /// The capture to write (trace format, JSON Lines; replay it with `pmacwd replay`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// The check.yaml configuration the capture names (and whose servo rate times it); the
    /// default is `pmacwd serve`'s.
    #[arg(long, value_name = "NAME", default_value = pmacwd_emulator::card::DEFAULT_CONFIGURATION)]
    pub configuration: String,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
    /// The card's servo rate, 1..100000 Hz (the servo clock range of specs/scheduling.yaml;
    /// default: the configuration's; docs/emulator.md "Limits").
    #[arg(long, allow_negative_numbers = true, value_name = "HZ", value_parser = crate::common::servo_hz)]
    pub servo_hz: Option<u32>,
    /// Also proxy an emulator's control interface: listen here ...
    #[arg(long, value_name = "ADDR", requires = "control_target", value_parser = listen_address)]
    pub control_listen: Option<SocketAddr>,
    /// ... and forward to this one; its events go into the capture.
    #[arg(long, value_name = "ADDR", requires = "control_listen")]
    pub control_target: Option<String>,
    /// Time only from the proxied control interface's `step` commands (an emulator in
    /// virtual time): exact to the servo cycle.
    #[arg(long, requires = "control_target")]
    pub virtual_time: bool,
    /// No reply byte for this long counts as silence (a tripped card).
    #[arg(long, allow_negative_numbers = true, value_name = "MS", default_value_t = 1000, value_parser = crate::common::ranged(1u64, 3_600_000, " ms (at most an hour)"))]
    pub silence_ms: u64,
    /// Stop after this many host sessions have ended (default: run until killed; every
    /// exchange goes to the capture's writer as it completes, and is on disk shortly after).
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = crate::common::ranged(1u64, u64::MAX, ""))]
    pub sessions: Option<u64>,
    /// Log sessions, and each one whose card could not be reached or whose thread could not
    /// be started, to standard error (without it, those are summed up on one line at most once
    /// a minute).
    #[arg(long)]
    pub verbose: bool,
}

pub fn record(a: RecordArgs) -> ExitCode {
    let model = match model_config(&a.specs, &a.configuration, None) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    let servo_hz = match pmacwd_emulator::card::servo_rate(a.servo_hz, &model) {
        Ok(hz) => hz,
        Err(e) => return unusable(e),
    };
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
        silence: Duration::from_millis(a.silence_ms),
        sessions: a.sessions,
        verbose: a.verbose,
        thread_stack_bytes: None,
    };
    // The capture is written by a thread of its own, so that a stalled sink holds no session.
    let recorder = match Recorder::new(capture, servo_hz, a.virtual_time) {
        Ok(r) => r,
        Err(e) => return unusable(format!("{}: cannot start the capture's writer: {e}", a.out.display())),
    };
    let proxy = match Proxy::start(recorder, options) {
        Ok(p) => p,
        Err(e) => return unusable(format!("cannot listen: {e}")),
    };
    to_stdout(format_args!(
        "pmacwd record: {} -> {}{}, writing {}",
        proxy.local_addr,
        a.target,
        match (proxy.control_addr, &a.control_target) {
            (Some(l), Some(t)) => format!(" (control {l} -> {t})"),
            _ => String::new(),
        },
        a.out.display()
    ));
    crate::common::console_may_close();
    // Until --sessions host sessions have ended, or SIGINT or SIGTERM asks for a stop.
    crate::interrupt::install();
    let signal = crate::interrupt::wait_for_stop(|| proxy.sessions_ended());
    match proxy.stop() {
        Ok((exchanges, steps, notes)) => {
            if let Some(signal) = signal {
                to_stdout(format_args!("pmacwd record: stopped by {signal}"));
            }
            for n in notes {
                to_stderr(format_args!("pmacwd record: left over at the end: {n}"));
            }
            to_stdout(format_args!(
                "recorded {} as {} in {}",
                crate::common::plural(exchanges, "exchange", "exchanges"),
                crate::common::plural(steps, "step", "steps"),
                a.out.display()
            ));
            ExitCode::SUCCESS
        }
        Err(e) => unusable(format!("{}: {e}", a.out.display())),
    }
}
