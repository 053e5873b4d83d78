//! `pmacwd control`: a small client for the control port of `pmacwd serve` (and of `pmacwd
//! record --control-listen`), so that a test bench needs no `nc` (a Debian image has none).
//!
//! Every command is one line and gets one reply line (`ok ...` or `error: ...`,
//! `emulator/src/control.rs`). Commands come from the arguments, one per argument, or else
//! from standard input, one per line; each reply is printed as it arrives.

use pmacwd_emulator::control::read_line_max;
use std::io::{self, BufRead, BufReader, IsTerminal, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::ExitCode;
use std::time::Duration;

/// How long to wait for the connection: a control port on loopback answers at once; a host
/// that does not answer within this is not there.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// How long to wait for one reply. The slowest command is a `step` of many servo cycles, run in
/// chunks of `CYCLES_PER_HOLD_MAX` with the card lock released between them (about 4 s for a
/// billion cycles, issue 15); a minute leaves room for a loaded machine and still ends a
/// session with an emulator that stopped answering.
const REPLY_TIMEOUT: Duration = Duration::from_secs(60);

/// A reply line is at most this long: a state or a step is a few hundred bytes, `help` about
/// 300; 64 KiB leaves room for any future reply while a peer that never ends its line cannot
/// fill memory.
const REPLY_BYTES_MAX: usize = 64 * 1024;

/// The options of `pmacwd control`.
pub struct ControlArgs {
    pub address: SocketAddr,
    pub commands: Vec<String>,
}

pub fn control(a: ControlArgs) -> ExitCode {
    let ControlArgs { address, commands } = a;
    let stream = match TcpStream::connect_timeout(&address, CONNECT_TIMEOUT) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("pmacwd: control port {address}: {e} (is `pmacwd serve` running? its control port is --control, default 127.0.0.1:1026)");
            return ExitCode::from(2);
        }
    };
    if let Err(e) = stream.set_read_timeout(Some(REPLY_TIMEOUT)) {
        eprintln!("pmacwd: control port {address}: {e}");
        return ExitCode::from(2);
    }
    let mut session = match Session::new(stream) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("pmacwd: control port {address}: {e}");
            return ExitCode::from(2);
        }
    };
    let outcome = if commands.is_empty() { from_stdin(&mut session) } else { from_args(&mut session, &commands) };
    match outcome {
        Ok(0) => ExitCode::SUCCESS,
        Ok(_) => ExitCode::from(1),
        Err(e) => {
            eprintln!("pmacwd: control port {address}: {e}");
            ExitCode::from(2)
        }
    }
}

/// One connection to a control port.
struct Session {
    writer: TcpStream,
    reader: BufReader<TcpStream>,
    line: Vec<u8>,
}

impl Session {
    fn new(stream: TcpStream) -> io::Result<Session> {
        Ok(Session { reader: BufReader::new(stream.try_clone()?), writer: stream, line: Vec::new() })
    }

    /// Sends one command and returns its reply line, without its newline.
    fn ask(&mut self, command: &str) -> io::Result<String> {
        if command.contains('\n') || command.contains('\r') {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("`{}`: one command per line", command.escape_debug()),
            ));
        }
        self.writer.write_all(format!("{command}\n").as_bytes())?;
        if !read_line_max(&mut self.reader, &mut self.line, REPLY_BYTES_MAX)? {
            return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "the emulator closed the connection"));
        }
        let text = String::from_utf8_lossy(&self.line);
        Ok(text.trim_end_matches(['\n', '\r']).to_string())
    }
}

/// Prints one reply; `true` when it is an error.
fn report(reply: &str) -> io::Result<bool> {
    writeln!(io::stdout(), "{reply}")?;
    Ok(reply.starts_with("error"))
}

/// The commands of the arguments; returns how many were answered with an error.
fn from_args(session: &mut Session, commands: &[String]) -> io::Result<usize> {
    let mut errors = 0;
    for command in commands {
        let reply = session.ask(command.trim())?;
        errors += usize::from(report(&reply)?);
    }
    Ok(errors)
}

/// Commands from standard input, one per line; on a terminal with a prompt. Blank lines and
/// `#` comments are skipped, so a file of commands can be annotated. Returns how many were
/// answered with an error.
fn from_stdin(session: &mut Session) -> io::Result<usize> {
    let mut errors = 0;
    let stdin = io::stdin();
    let prompt = stdin.is_terminal();
    let mut input = stdin.lock();
    let mut line = String::new();
    loop {
        if prompt {
            print!("control> ");
            io::stdout().flush()?;
        }
        line.clear();
        if input.read_line(&mut line)? == 0 {
            return Ok(errors);
        }
        let command = line.trim();
        if command.is_empty() || command.starts_with('#') {
            continue;
        }
        if matches!(command, "quit" | "exit") && prompt {
            return Ok(errors);
        }
        let reply = session.ask(command)?;
        errors += usize::from(report(&reply)?);
    }
}
