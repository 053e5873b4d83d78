//! Captures written off every lock a host shares (issue 33): `serve --record`'s card and
//! `pmacwd record`'s proxy (`proxy::Recorder`) hand each record to a queue and a thread of its
//! own writes the capture. A sink that stops taking bytes (a FIFO nobody reads, a full or hung
//! disk) used to block the write under the card's lock (the proxy's recorder lock), and with
//! it every host and the control port. Now neither waits for the sink: when the records
//! waiting pass [`QUEUE_BYTES_MAX`], recording stops, standard error says so at once, and the
//! capture ends with a note saying why once the sink takes it. The capture then holds every
//! exchange up to that point and nothing after it, so its replay judges a true prefix of the
//! session rather than a session with holes.

use crate::bounded::{spawn, to_stderr};
use crate::capture::CaptureWriter;
use pmacwd_specs::grammar::{Addressing, Command, Unreadable};
use pmacwd_trace::Step;
use std::io::{self, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

/// The bytes of records that may wait for the writer. A host line makes records of a few
/// hundred bytes per command; at the emulator's fastest (about 70,000 lines a second) 4 MiB
/// is tens of milliseconds of a busy session, far more than any working sink falls behind,
/// and little memory for a server.
pub const QUEUE_BYTES_MAX: usize = 4 << 20;

/// How long the end of a recording waits for the writer to write what is queued.
pub const FINISH_WAIT: Duration = Duration::from_secs(5);

/// What the card (or the proxy) records, in the order it happened.
pub enum Record {
    /// A whole line and its reply (`None`: silence), read again with the card's grammar from
    /// `addressing`: a line the card answered at once (a tripped card, a byte above 127), and
    /// every exchange `pmacwd record` sees.
    Line { line: String, addressing: Addressing, reply: Option<Vec<u8>> },
    /// Commands run in one hold of the card's lock and their answers: see
    /// [`CaptureWriter::commands`].
    Commands { commands: Vec<(String, Result<Command, Unreadable>)>, reply: Option<Vec<u8>> },
    /// An event the bench caused (a control command).
    Event(Step),
    /// A note for the next step ([`CaptureWriter::note`]): program text sent to an open buffer
    /// (the model keeps none), a proxy's own remarks.
    Note(String),
    /// Recording stopped: the capture ends with this note.
    Stopped(String),
}

impl Record {
    /// What the record holds in memory, roughly: enough to bound the queue.
    fn bytes(&self) -> usize {
        const FIXED: usize = 128;
        FIXED
            + match self {
                Record::Line { line, reply, .. } => line.len() + reply.as_ref().map_or(0, Vec::len),
                Record::Commands { commands, reply } => {
                    commands.iter().map(|(t, _)| t.len() + FIXED).sum::<usize>() + reply.as_ref().map_or(0, Vec::len)
                }
                Record::Event(_) => FIXED,
                Record::Note(s) | Record::Stopped(s) => s.len(),
            }
    }
}

/// A record and the servo cycles that passed before it.
struct Queued {
    cycles_before: u64,
    record: Record,
}

/// The card's end of the capture: records go in without waiting; the writer thread takes them.
pub struct CaptureQueue {
    /// `None` once recording stopped.
    to_writer: Option<mpsc::Sender<Queued>>,
    /// Servo cycles not yet handed over: they go with the next record, so that the clock's
    /// catch-ups do not each make a record.
    cycles: u64,
    queued_bytes: Arc<AtomicUsize>,
    /// Set by the writer when the sink failed (it has said why).
    failed: Arc<AtomicBool>,
    steps: Arc<AtomicU64>,
    done: mpsc::Receiver<Vec<String>>,
    /// Who speaks on standard error: `pmacwd serve`, `pmacwd record`.
    who: &'static str,
}

impl CaptureQueue {
    /// Starts the writer thread for `capture` (its header is already written); `who` names
    /// the program in the messages on standard error (`pmacwd serve`).
    pub fn start(capture: CaptureWriter<Box<dyn Write + Send>>, who: &'static str) -> io::Result<CaptureQueue> {
        let (to_writer, from_card) = mpsc::channel::<Queued>();
        let (done_tx, done) = mpsc::sync_channel(1);
        let queued_bytes = Arc::new(AtomicUsize::new(0));
        let failed = Arc::new(AtomicBool::new(false));
        let steps = Arc::new(AtomicU64::new(capture.steps));
        let (q, f, st) = (queued_bytes.clone(), failed.clone(), steps.clone());
        spawn(format!("{who}: capture writer"), None, move || {
            let _ = done_tx.send(write_all(capture, &from_card, &q, &f, &st, who));
        })?;
        Ok(CaptureQueue { to_writer: Some(to_writer), cycles: 0, queued_bytes, failed, steps, done, who })
    }

    /// Whether records are still being written.
    pub fn is_recording(&self) -> bool {
        self.to_writer.is_some() && !self.failed.load(Ordering::Relaxed)
    }

    /// `cycles` servo cycles passed.
    pub fn elapse(&mut self, cycles: u64) {
        self.cycles = self.cycles.saturating_add(cycles);
    }

    /// Queues `record` without waiting; stops recording, with a message on standard error,
    /// when the sink has fallen [`QUEUE_BYTES_MAX`] behind. Whether it was queued.
    pub fn send(&mut self, record: Record) -> bool {
        let Some(tx) = &self.to_writer else { return false };
        let bytes = record.bytes();
        let waiting = self.queued_bytes.fetch_add(bytes, Ordering::Relaxed) + bytes;
        if waiting > QUEUE_BYTES_MAX {
            self.queued_bytes.fetch_sub(bytes, Ordering::Relaxed);
            let why = format!(
                "recording stopped: the capture's sink took nothing while {waiting} bytes of records waited (at most {QUEUE_BYTES_MAX}): a FIFO nobody reads, a full or hung disk; the capture holds the session up to here, and nothing after it"
            );
            to_stderr(format_args!("{}: {why}", self.who));
            // One small record past the bound, so that the capture itself says why it ends.
            let _ = tx.send(Queued { cycles_before: 0, record: Record::Stopped(why) });
            self.to_writer = None;
            return false;
        }
        let queued = Queued { cycles_before: std::mem::take(&mut self.cycles), record };
        if tx.send(queued).is_err() {
            // The writer ended (the sink failed, and the writer said so).
            self.to_writer = None;
            return false;
        }
        true
    }

    /// Ends the recording: waits up to `wait` for the writer to write what is queued. Returns
    /// the steps written and the notes that found no step (the sink's failure among them).
    pub fn finish(mut self, wait: Duration) -> (u64, Vec<String>) {
        self.to_writer = None;
        match self.done.recv_timeout(wait) {
            Ok(notes) => (self.steps.load(Ordering::Relaxed), notes),
            Err(_) => (
                self.steps.load(Ordering::Relaxed),
                vec![format!(
                    "the capture's sink took nothing for {} s at the end: {} bytes of records were not written",
                    wait.as_secs(),
                    self.queued_bytes.load(Ordering::Relaxed)
                )],
            ),
        }
    }
}

/// The writer thread: every record in turn, until the card's end closes or the sink fails.
fn write_all(
    mut capture: CaptureWriter<Box<dyn Write + Send>>,
    from_card: &mpsc::Receiver<Queued>,
    queued_bytes: &AtomicUsize,
    failed: &AtomicBool,
    steps: &AtomicU64,
    who: &str,
) -> Vec<String> {
    for Queued { cycles_before, record } in from_card.iter() {
        queued_bytes.fetch_sub(record.bytes(), Ordering::Relaxed);
        capture.elapse(cycles_before);
        let written = match &record {
            Record::Line { line, addressing, reply } => capture.exchange_addressed(line, *addressing, reply.as_deref()),
            Record::Commands { commands, reply } => capture.commands(commands, reply.as_deref()),
            Record::Event(step) => capture.event(step.clone()),
            Record::Note(note) => {
                capture.note(note.clone());
                Ok(())
            }
            Record::Stopped(why) => {
                capture.note(why.clone());
                Ok(())
            }
        };
        steps.store(capture.steps, Ordering::Relaxed);
        if let Err(e) = written {
            // A full disk must not stop the emulator: say so once and stop recording.
            to_stderr(format_args!("{who}: recording stopped: {e}"));
            failed.store(true, Ordering::Relaxed);
            return vec![format!("recording stopped: {e}")];
        }
    }
    capture.finish().unwrap_or_else(|e| vec![format!("the capture could not be completed: {e}")])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::Timing;
    use std::sync::Mutex;

    /// A sink the test can read while the writer holds it.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);
    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn records_are_written_in_order_with_the_cycles_before_each() {
        let sink = Shared::default();
        let capture =
            CaptureWriter::new(Box::new(sink.clone()) as Box<dyn Write + Send>, "t", "i40-zero", Timing::Exact)
                .unwrap();
        let mut q = CaptureQueue::start(capture, "test").unwrap();
        q.elapse(2);
        q.elapse(3);
        q.send(Record::Line {
            line: "???".into(),
            addressing: Addressing::default(),
            reply: Some(b"000000000000\r\x06".to_vec()),
        });
        let (steps, notes) = q.finish(FINISH_WAIT);
        assert!(notes.is_empty(), "{notes:?}");
        assert_eq!(steps, 2, "one run step of 5 cycles, then the command");
        let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[1], r#"{"run":5}"#);
        assert!(lines[2].contains("???"), "{}", lines[2]);
    }

    #[test]
    fn a_failing_sink_stops_recording_and_says_why() {
        struct Full;
        impl Write for Full {
            fn write(&mut self, _: &[u8]) -> io::Result<usize> {
                Err(io::Error::other("no space left on device"))
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        // The header goes through; the first step meets a full disk.
        let capture = CaptureWriter::new(
            Box::new(FailAfterHeader(false, Full)) as Box<dyn Write + Send>,
            "t",
            "i40-zero",
            Timing::Exact,
        )
        .unwrap();
        let mut q = CaptureQueue::start(capture, "test").unwrap();
        q.send(Record::Line { line: "???".into(), addressing: Addressing::default(), reply: None });
        let (_, notes) = q.finish(FINISH_WAIT);
        assert!(notes.iter().any(|n| n.contains("no space left")), "{notes:?}");
    }

    /// Takes the header line, then passes writes to the inner sink.
    struct FailAfterHeader<W>(bool, W);
    impl<W: Write> Write for FailAfterHeader<W> {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if self.0 {
                self.1.write(buf)
            } else {
                Ok(buf.len())
            }
        }
        fn flush(&mut self) -> io::Result<()> {
            self.0 = true;
            Ok(())
        }
    }
}
