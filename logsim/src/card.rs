//! A correct card, written from the manual pages alone (docs/independent-logs.md lists every
//! rule with its page). Nothing here comes from the project's model: the rules are read off
//! the User Manual (UM) and the Software Reference (SRM) as the seed excerpts and the public
//! manual pages print them, and where the pages leave a choice open the card takes the option
//! its `Readings` name.
//!
//! Time is counted in servo cycles. Each servo cycle runs, in the priority order of UM p.236:
//! the servo interrupt (with the watchdog counter's decrement, UM p.215), the real-time
//! interrupt every I8+1 cycles (UM p.236), then whatever CPU time is left goes to the
//! background, whose cycles answer host commands and reload the counter (UM p.236-237, p.215).

use std::collections::BTreeMap;

/// The readings where the manuals disagree (turbo-pmac-facts.md section 6). Each is chosen per
/// generated log and written to its sidecar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Readings {
    /// With I40 = 0 the reload is 4096 (UM p.215, UM p.237) rather than 4095 (SRM p.57).
    pub reset_4096: bool,
    /// The counter is decremented every servo cycle and strobing stops once it is below 0
    /// (SRM p.57), rather than decremented only while above 0 (UM p.215).
    pub stop_below_zero: bool,
    /// The real-time interrupt task strobes the watchdog (SRM p.57), rather than the
    /// servo-interrupt routine (UM p.215).
    pub strober_rti: bool,
    /// Bit 12 of X:$000006 is the firmware checksum error bit (suggested M-variable M83),
    /// rather than "PROM checksum active" (SRM p.289).
    pub bit12_m83: bool,
    /// The timer needs about 50 Hz (older PMAC manual) rather than about 25 Hz (UM p.215).
    pub hz_50: bool,
    /// Bit 9 stays set until reset like bit 22, rather than reporting the latest RTI (SRM
    /// p.290 calls only bit 22 sticky).
    pub bit9_sticky: bool,
}

impl Readings {
    pub fn names(&self) -> Vec<(&'static str, &'static str)> {
        vec![
            ("reset_value_when_i40_zero", if self.reset_4096 { "4096" } else { "4095" }),
            ("strobe_stop", if self.stop_below_zero { "below_zero" } else { "at_zero" }),
            ("strober", if self.strober_rti { "real_time_interrupt" } else { "servo_interrupt" }),
            ("bit12_meaning", if self.bit12_m83 { "firmware_checksum_error" } else { "prom_checksum_active" }),
            ("strobe_hz_min", if self.hz_50 { "50" } else { "25" }),
            ("rti_warning_latch", if self.bit9_sticky { "sticky" } else { "level" }),
        ]
    }
}

/// What is fixed about one card: its hardware, its saved settings and its load.
#[derive(Clone, Debug)]
pub struct CardSpec {
    /// I10, the servo interrupt time in units of 1/8,388,608 ms (SRM p.43; PMAC SRM p.28:
    /// default 3,713,707, about 2.26 kHz).
    pub i10: u32,
    /// The card's actual servo clock (Hz): 8,388,608,000 / I10 off by the crystal's error.
    pub servo_hz: f64,
    /// The CPU type (0 DSP56303, 1 DSP56309, 2 DSP56311, 3 DSP56321): bits 21 of both `???`
    /// words (SRM p.289).
    pub cpu: u8,
    /// This card's own strobe minimum in Hz ("approximately 25 Hz", UM p.215).
    pub strobe_hz_min: f64,
    /// This card's own supply minimum in millivolts ("approximately 4.75V", UM p.215).
    pub supply_min_mv: u32,
    /// Background cycles a firmware checksum pass takes, and a user-program pass (UM p.217:
    /// both are computed "continually ... as a background task"; no page gives a length).
    pub firmware_pass_cycles: u32,
    pub user_pass_cycles: u32,
    /// CPU units per servo cycle taken by the servo tasks (of 100; UM p.236, p.176).
    pub servo_units: u32,
    /// CPU units one background cycle needs (UM p.236: the more background tasks, the slower).
    pub background_units: u32,
    /// The saved I-variables (flash), copied into active memory at every power-up/reset
    /// (UM p.7 "Flash Memory"). I8, I40, I41 and the card's own I5, I10, I15, I130, ...
    pub saved: BTreeMap<u32, i64>,
}

impl CardSpec {
    /// The hardware delay in servo cycles: the strobe toggles once per edge, so a square wave
    /// of frequency F has an edge every 1/(2F) s; the timer trips when no edge comes for
    /// longer than that at its minimum frequency (UM p.215).
    pub fn delay_cycles(&self) -> u32 {
        (self.servo_hz / (2.0 * self.strobe_hz_min)).floor() as u32
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Area {
    Firmware,
    UserProgram,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Why {
    /// The watchdog counter ran out and the strobe stopped (UM p.215).
    Starvation,
    /// The supply fell below the minimum (UM p.215).
    SupplyDip,
}

#[derive(Clone, Debug)]
pub enum Power {
    Running,
    /// Latched reset state: the processor stops and will not communicate (UM p.215).
    Tripped {
        why: Why,
        at_cycle: u64,
    },
    /// Restarting after INIT/, power-up or `$$$`: silent until the time given (host seconds).
    Booting {
        until_s: f64,
    },
}

/// One card as it runs.
#[derive(Clone, Debug)]
pub struct Card {
    pub spec: CardSpec,
    pub readings: Readings,
    /// Host seconds at the start of the next servo cycle.
    pub now_s: f64,
    /// Servo cycles since this simulation began (not X:$0: that restarts at every reset).
    pub cycles_total: u64,
    /// X:$000000, the 24-bit servo cycle counter.
    pub x0: u32,
    /// Y:$000025, the watchdog counter (signed: it goes below 0 under SRM p.57).
    pub counter: i64,
    /// X:$000025, the lowest value of the counter since power-on/reset (SRM p.57).
    pub x25: i64,
    pub cycles_since_edge: u32,
    pub rti_phase: u32,
    /// CPU units of RTI tasks still to run from the last RTI.
    pub rti_pending: u64,
    /// PLC 0's cost per RTI (0: disabled). `u64::MAX / 4` stands for a PLC 0 that never ends
    /// its scan (a loop waiting on a condition).
    pub plc0_units: u64,
    pub background_progress: u64,
    pub bit22: bool,
    pub bit9: bool,
    pub bit10: bool,
    pub bit11: bool,
    pub area: Area,
    pub pass_done: u32,
    pub corrupt_firmware: bool,
    pub corrupt_user: bool,
    /// A checksum error found: bit 13, and which area (UM p.217).
    pub checksum_error: Option<Area>,
    pub supply_mv: u32,
    pub power: Power,
    /// The active I-variables (read and written by the host).
    pub ivars: BTreeMap<u32, i64>,
    /// A command line the card has received and not yet answered.
    pending: Option<Vec<Cmd>>,
    /// The answer to the last command line, once a background cycle has answered it.
    answered: Option<Vec<Answer>>,
    /// Background cycles completed since the last reset.
    pub background_cycles: u64,
}

/// A command as the generator sends it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Cmd {
    Status,
    ReadX0,
    ReadY25,
    ReadX25,
    ReadI(u32),
    WriteI(u32, i64),
    Reset,
    EnablePlc0,
    DisablePlc0,
}

impl Cmd {
    pub fn text(&self) -> String {
        match self {
            Cmd::Status => "???".into(),
            Cmd::ReadX0 => "RHX:$0".into(),
            Cmd::ReadY25 => "RHY:$25".into(),
            Cmd::ReadX25 => "RHX:$25".into(),
            Cmd::ReadI(n) => format!("I{n}"),
            Cmd::WriteI(n, v) => format!("I{n}={v}"),
            Cmd::Reset => "$$$".into(),
            Cmd::EnablePlc0 => "ENABLE PLC 0".into(),
            Cmd::DisablePlc0 => "DISABLE PLC 0".into(),
        }
    }
}

/// A value the card answered; `None` for a command that only acknowledges.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Answer {
    Ack,
    Status { x: u32, y: u32 },
    Word(u32),
    Value(i64),
}

impl Answer {
    pub fn text(&self) -> Option<String> {
        match self {
            Answer::Ack => None,
            // Twelve hex characters, X:$000006 then Y:$000006 (SRM p.289).
            Answer::Status { x, y } => Some(format!("{x:06X}{y:06X}")),
            // A register read in hex: 24 bits, six digits.
            Answer::Word(w) => Some(format!("{:06X}", w & 0xFF_FFFF)),
            Answer::Value(v) => Some(format!("{v}")),
        }
    }
}

/// PLC 0 that never finishes a scan.
pub const PLC0_ENDLESS: u64 = u64::MAX / 4;

/// The CPU units of one servo cycle (a scale of our own: loads are fractions of it).
pub const CYCLE_UNITS: u64 = 100;

/// I-variable lockout ranges of I41's bits (SRM p.57).
pub fn locked_by_i41(i41: i64, n: u32) -> bool {
    let ranges = [(1, 100, 4899), (2, 5100, 6699), (4, 6800, 7999), (8, 8000, 8191)];
    ranges.iter().any(|&(bit, lo, hi)| i41 & bit != 0 && (lo..=hi).contains(&n))
}

impl Card {
    /// A card just powered up at host time `now_s`, its boot over (UM p.215: power restores
    /// normal functioning).
    pub fn new(spec: CardSpec, readings: Readings, now_s: f64) -> Card {
        let mut card = Card {
            ivars: spec.saved.clone(),
            spec,
            readings,
            now_s,
            cycles_total: 0,
            x0: 0,
            counter: 0,
            x25: 0,
            cycles_since_edge: 0,
            rti_phase: 0,
            rti_pending: 0,
            plc0_units: 0,
            background_progress: 0,
            bit22: false,
            bit9: false,
            bit10: false,
            bit11: false,
            area: Area::Firmware,
            pass_done: 0,
            corrupt_firmware: false,
            corrupt_user: false,
            checksum_error: None,
            supply_mv: 5000,
            power: Power::Running,
            pending: None,
            answered: None,
            background_cycles: 0,
        };
        card.restart_state(false, false);
        card
    }

    pub fn i8(&self) -> u32 {
        self.ivars.get(&8).copied().unwrap_or(2).clamp(0, 255) as u32
    }

    pub fn i40(&self) -> i64 {
        self.ivars.get(&40).copied().unwrap_or(0)
    }

    pub fn i41(&self) -> i64 {
        self.ivars.get(&41).copied().unwrap_or(0)
    }

    /// The value the background cycle resets the counter to: I40, or with I40 = 0 4096
    /// (UM p.215) or 4095 (SRM p.57) by the reading.
    pub fn reload(&self) -> i64 {
        match self.i40() {
            0 if self.readings.reset_4096 => 4096,
            0 => 4095,
            v => v,
        }
    }

    pub fn servo_period_s(&self) -> f64 {
        1.0 / self.spec.servo_hz
    }

    pub fn is_running(&self) -> bool {
        matches!(self.power, Power::Running)
    }

    /// What a reset leaves (UM p.215: power cycle or INIT/; SRM `$$$`): the counter and X:$25
    /// start from the reload value (X:$25 is the lowest "since the last power-on/reset", SRM
    /// p.57), the sticky RTI bit is cleared ("until the card is reset", SRM p.289), the
    /// checksums start over, X:$0 counts from 0, and the saved I-variables are copied from
    /// flash into active memory (UM p.7).
    fn restart_state(&mut self, dpram_error: bool, flash_error: bool) {
        self.ivars = self.spec.saved.clone();
        self.x0 = 0;
        self.counter = self.reload();
        self.x25 = self.counter;
        self.cycles_since_edge = 0;
        self.rti_phase = 0;
        self.rti_pending = 0;
        self.plc0_units = 0;
        self.background_progress = 0;
        self.bit22 = false;
        self.bit9 = false;
        // Bits 11 and 10: found by the checks at power-up/reset (SRM p.289).
        self.bit11 = dpram_error;
        self.bit10 = flash_error;
        self.area = Area::Firmware;
        self.pass_done = 0;
        self.corrupt_firmware = false;
        self.corrupt_user = false;
        self.checksum_error = None;
        self.pending = None;
        self.answered = None;
        self.background_cycles = 0;
    }

    /// INIT/ pulsed, power cycled, or `$$$`: silent for `boot_s`, then running from a reset.
    pub fn reset(&mut self, boot_s: f64, dpram_error: bool, flash_error: bool) {
        self.restart_state(dpram_error, flash_error);
        self.power = Power::Booting { until_s: self.now_s + boot_s };
    }

    /// The two status words of `???` (SRM p.289-290).
    pub fn status_words(&self) -> (u32, u32) {
        let mut x = 0u32;
        let mut y = 0u32;
        let cpu_hi = self.spec.cpu >> 1 & 1;
        let cpu_lo = self.spec.cpu & 1;
        x |= u32::from(self.bit22) << 22;
        x |= u32::from(cpu_hi) << 21;
        y |= u32::from(cpu_lo) << 21;
        let bit13 = self.checksum_error.is_some();
        let bit12 = if self.readings.bit12_m83 {
            // M83: 1 only after a firmware checksum error.
            self.checksum_error == Some(Area::Firmware)
        } else {
            // SRM p.289: 1 while evaluating the firmware checksum (13 = 0) or after a
            // firmware checksum error (13 = 1); 0 for the user program.
            match self.checksum_error {
                Some(area) => area == Area::Firmware,
                None => self.area == Area::Firmware,
            }
        };
        x |= u32::from(bit13) << 13;
        x |= u32::from(bit12) << 12;
        x |= u32::from(self.bit11) << 11;
        x |= u32::from(self.bit10) << 10;
        x |= u32::from(self.bit9) << 9;
        (x, y)
    }

    fn answer(&mut self, cmd: &Cmd) -> Answer {
        match cmd {
            Cmd::Status => {
                let (x, y) = self.status_words();
                Answer::Status { x, y }
            }
            Cmd::ReadX0 => Answer::Word(self.x0),
            Cmd::ReadY25 => Answer::Word((self.counter as u32) & 0xFF_FFFF),
            Cmd::ReadX25 => Answer::Word((self.x25 as u32) & 0xFF_FFFF),
            Cmd::ReadI(n) => Answer::Value(self.ivars.get(n).copied().unwrap_or(0)),
            Cmd::WriteI(n, v) => {
                // I41: a write to a locked set is ignored, with no error (SRM p.57).
                if !locked_by_i41(self.i41(), *n) {
                    self.ivars.insert(*n, *v);
                }
                Answer::Ack
            }
            Cmd::Reset => Answer::Ack,
            // PLC 0 runs at every RTI as long as the tasks of the previous RTI completed
            // (UM p.236); its cost is set by the scenario (`set_plc0_units`).
            Cmd::EnablePlc0 | Cmd::DisablePlc0 => Answer::Ack,
        }
    }

    /// The background cycle (UM p.236-237): it responds to a host command, if any, and does
    /// its housekeeping (the checksums, UM p.217); at its end the counter is reset to the
    /// reload value (UM p.215; SRM p.57). Returns true when the command was `$$$`.
    fn background_cycle(&mut self) -> bool {
        self.background_cycles += 1;
        let mut reset = false;
        if let Some(line) = self.pending.take() {
            let mut answers = Vec::new();
            for cmd in &line {
                answers.push(self.answer(cmd));
                if *cmd == Cmd::Reset {
                    reset = true;
                    break;
                }
            }
            self.answered = Some(answers);
        }
        if reset {
            return true;
        }
        // The checksums (UM p.217): a pass over one area, then the other, continually; a
        // mismatch sets bit 13 (bit 12 by the area, SRM p.289) and stops all checksumming.
        if self.checksum_error.is_none() {
            self.pass_done += 1;
            let (length, corrupt) = match self.area {
                Area::Firmware => (self.spec.firmware_pass_cycles, self.corrupt_firmware),
                Area::UserProgram => (self.spec.user_pass_cycles, self.corrupt_user),
            };
            if self.pass_done >= length {
                self.pass_done = 0;
                if corrupt {
                    self.checksum_error = Some(self.area);
                } else {
                    self.area = match self.area {
                        Area::Firmware => Area::UserProgram,
                        Area::UserProgram => Area::Firmware,
                    };
                }
            }
        }
        self.counter = self.reload();
        false
    }

    /// One servo cycle.
    pub fn servo_cycle(&mut self) {
        self.now_s += self.servo_period_s();
        self.cycles_total += 1;
        if !self.is_running() {
            return;
        }
        self.x0 = (self.x0 + 1) & 0xFF_FFFF;
        // The servo interrupt decrements the counter (UM p.215: "as long as the counter is
        // greater than zero"; SRM p.57: every cycle, strobing stops once it is below 0).
        let strobing = if self.readings.stop_below_zero {
            self.counter -= 1;
            self.counter >= 0
        } else if self.counter > 0 {
            self.counter -= 1;
            true
        } else {
            false
        };
        self.x25 = self.x25.min(self.counter);
        let mut edge = strobing && !self.readings.strober_rti;
        // The RTI, every I8+1 servo cycles (UM p.236). PLC 0 runs "as long as the tasks
        // from the previous RTI have been completed" (UM p.236); if they have not, the RTI
        // re-entered: bit 22 (sticky, SRM p.289) and bit 9 (SRM p.290).
        self.rti_phase += 1;
        if self.rti_phase > self.i8() {
            self.rti_phase = 0;
            if self.rti_pending > 0 {
                self.bit22 = true;
                self.bit9 = true;
            } else {
                if !self.readings.bit9_sticky {
                    self.bit9 = false;
                }
                self.rti_pending = self.plc0_units;
            }
            // SRM p.57: the real-time interrupt task strobes while the counter allows it.
            if self.readings.strober_rti && strobing {
                edge = true;
            }
        }
        // The hardware timer: trips when no edge came for longer than its delay (UM p.215).
        if edge {
            self.cycles_since_edge = 0;
        } else {
            self.cycles_since_edge += 1;
            if self.cycles_since_edge > self.spec.delay_cycles() {
                self.power = Power::Tripped { why: Why::Starvation, at_cycle: self.cycles_total };
                return;
            }
        }
        // CPU time: the servo tasks first, the RTI tasks next, the background gets the rest
        // (UM p.236).
        let mut budget = CYCLE_UNITS.saturating_sub(u64::from(self.spec.servo_units));
        let rti = self.rti_pending.min(budget);
        self.rti_pending -= rti;
        budget -= rti;
        self.background_progress += budget;
        let need = u64::from(self.spec.background_units.max(1));
        let mut completed = 0;
        while self.background_progress >= need && completed < 8 {
            self.background_progress -= need;
            completed += 1;
            if self.background_cycle() {
                // `$$$`: the card resets once it has acknowledged the line (SRM `$$$`; the
                // boot time, 0.3 s, is the generator's MODEL).
                let answered = self.answered.take();
                self.restart_state(false, false);
                self.answered = answered;
                self.power = Power::Booting { until_s: self.now_s + 0.3 };
                return;
            }
        }
        self.background_progress = self.background_progress.min(need);
    }

    /// Set the supply: below the card's minimum the relay trips at once (UM p.215).
    pub fn set_supply(&mut self, mv: u32) {
        self.supply_mv = mv;
        if mv < self.spec.supply_min_mv && self.is_running() {
            self.power = Power::Tripped { why: Why::SupplyDip, at_cycle: self.cycles_total };
        }
    }

    pub fn set_plc0_units(&mut self, units: u64) {
        self.plc0_units = units;
    }

    /// Corrupt memory that the background checksum will find (UM p.217).
    pub fn corrupt(&mut self, area: Area) {
        match area {
            Area::Firmware => self.corrupt_firmware = true,
            Area::UserProgram => self.corrupt_user = true,
        }
    }

    /// Run until host time `t_s`. A tripped card stays latched; a booting card starts when
    /// its boot is over.
    pub fn run_until(&mut self, t_s: f64) {
        while self.now_s < t_s {
            match self.power {
                Power::Running => self.servo_cycle(),
                Power::Tripped { .. } => {
                    self.now_s = t_s;
                }
                Power::Booting { until_s } => {
                    if until_s <= t_s {
                        self.now_s = self.now_s.max(until_s);
                        self.power = Power::Running;
                    } else {
                        self.now_s = t_s;
                    }
                }
            }
        }
    }

    /// Send a command line at the card's current time; run until a background cycle answers
    /// it or until `deadline_s` (host seconds). Returns the answers, or `None` when silent.
    pub fn exchange(&mut self, line: Vec<Cmd>, deadline_s: f64) -> Option<Vec<Answer>> {
        if !self.is_running() {
            self.run_until(deadline_s);
            return None;
        }
        self.pending = Some(line);
        self.answered = None;
        while self.now_s < deadline_s {
            if !self.is_running() {
                // Tripped (or reset by `$$$`, whose answer was given before): silent now.
                if let Some(answers) = self.answered.take() {
                    return Some(answers);
                }
                self.pending = None;
                self.run_until(deadline_s);
                return None;
            }
            self.servo_cycle();
            if let Some(answers) = self.answered.take() {
                return Some(answers);
            }
        }
        // The host gives up and flushes the line (MODEL of the generator: a late answer is
        // never delivered).
        self.pending = None;
        None
    }
}
