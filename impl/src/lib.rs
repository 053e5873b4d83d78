//! # pmacwd-core: the compact Turbo PMAC watchdog core
//!
//! The semantics of the reference model (`model/`) with none of its cost: `no_std`, no
//! allocation, no dependencies, the state in a few machine words, the status words kept in
//! their 24-bit wire layout (a `???` reply is formatting, not translation), and
//! [`Core::advance`] running any number of idle servo cycles in constant time.
//!
//! Its constants are its own ([`bits`], [`LOCKOUT`], [`Profile`]): a test in `conformance/`
//! checks them against `specs/`, and lockstep tests check every event against the model.
//!
//! Citations: UM = Turbo PMAC User Manual, SRM = Software Reference.
#![no_std]
#![forbid(unsafe_code)]
#![deny(clippy::arithmetic_side_effects)]

pub mod counter;
pub mod motion;
#[doc(hidden)]
pub mod proofs;
pub mod rti;
mod stretch;
pub mod timers;

pub use counter::StrobeStop;
pub use motion::{MotionCommand, MotionConfig, MotorStatus};
use rti::Tick;

/// Status bit positions in the wire layout of X:$000006 / Y:$000006 (SRM p.289-290).
pub mod bits {
    /// X bit 22: RTI re-entry, sticky.
    pub const RTI_REENTRY: u32 = 1 << 22;
    /// X bit 20: servo error.
    pub const SERVO_ERROR: u32 = 1 << 20;
    /// X bit 13: any memory checksum error.
    pub const CHECKSUM_ERROR: u32 = 1 << 13;
    /// X bit 12: PROM checksum active (or the M83 firmware checksum error reading).
    pub const PROM_CHECKSUM_ACTIVE: u32 = 1 << 12;
    /// X bit 11: DPRAM error at power-up/reset.
    pub const DPRAM_ERROR: u32 = 1 << 11;
    /// X bit 10: flash error at reset.
    pub const FLASH_ERROR: u32 = 1 << 10;
    /// X bit 9: RTI warning.
    pub const RTI_WARNING: u32 = 1 << 9;
    /// X bit 19: data gathering on, from GATHER to ENDGATHER or a reset (SRM p.289, p.307).
    pub const DATA_GATHERING_ON: u32 = 1 << 19;
    /// Y bit 19: motion program buffer open.
    pub const MOTION_BUFFER_OPEN: u32 = 1 << 19;
    /// Y bit 17: PLC buffer open.
    pub const PLC_BUFFER_OPEN: u32 = 1 << 17;
    /// X bit 21: CPU type bit 1 (SRM p.289).
    pub const CPU_TYPE_1: u32 = 1 << 21;
    /// Y bit 21: CPU type bit 0 (SRM p.289).
    pub const CPU_TYPE_0: u32 = 1 << 21;
}

/// I41 lockout ranges by I41 bit (SRM p.57): motor, coordinate system, MACRO/Servo IC,
/// conversion table setup.
pub const LOCKOUT: [(u16, u16); 4] = [(100, 4899), (5100, 6699), (6800, 7999), (8000, 8191)];
/// Turbo PMAC has I0..I8191.
pub const I_VARIABLE_MAX: u16 = 8191;
/// Valid ranges of I8, I40, I41 (UM p.236, SRM p.57).
pub const I8_MAX: i64 = 255;
pub const I40_MAX: i64 = 65_535;
pub const I41_MAX: i64 = 15;
/// The factory defaults of I8, I40, I41, which `$$$***` puts in active memory (SRM p.42,
/// SRM p.57; UM p.243).
pub const I8_DEFAULT: u8 = 2;
pub const I40_DEFAULT: u16 = 0;
pub const I41_DEFAULT: u8 = 0;

/// Where the I-variables other than I8, I40 and I41 live. The watchdog core reads none of them,
/// so their storage is the embedding's choice and stays out of [`Core`], which keeps the core a
/// few machine words: a firmware has its memory map, an emulator a table of all 8192
/// ([`AllIVariables`]), a test a few slots ([`FewIVariables`]).
pub trait IVariableStore {
    /// The value of I`n`; `None` when this store does not know it (a core held to the
    /// reference model: never written since the last reset, so the card's own saved value).
    fn read(&self, n: u16) -> Option<i64>;
    /// Stores I`n` = `v`; `false` when the store has no room (answered ERR003).
    fn write(&mut self, n: u16, v: i64) -> bool;
    /// I`n` is no longer known: a write the core could not compute reached it.
    fn forget(&mut self, n: u16);
    /// Back to the values saved in flash: unknown in this core's configuration.
    fn restore(&mut self);
    /// The firmware's factory defaults in active memory, the saved values kept but unused
    /// (`$$$***`, UM p.243): all zero in this core's configuration.
    fn factory(&mut self);
}

/// Every I-variable I0..I8191, 128 KiB, each known once written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AllIVariables(pub [Option<i64>; I_VARIABLE_MAX as usize + 1]);

impl Default for AllIVariables {
    fn default() -> Self {
        AllIVariables([None; I_VARIABLE_MAX as usize + 1])
    }
}

impl IVariableStore for AllIVariables {
    fn read(&self, n: u16) -> Option<i64> {
        self.0.get(usize::from(n)).copied().flatten()
    }
    fn write(&mut self, n: u16, v: i64) -> bool {
        match self.0.get_mut(usize::from(n)) {
            Some(slot) => {
                *slot = Some(v);
                true
            }
            None => false,
        }
    }
    fn forget(&mut self, n: u16) {
        if let Some(slot) = self.0.get_mut(usize::from(n)) {
            *slot = None;
        }
    }
    fn restore(&mut self) {
        self.0 = [None; I_VARIABLE_MAX as usize + 1];
    }
    fn factory(&mut self) {
        self.restore();
    }
}

/// Up to `N` known I-variables in a small table; a write needing more answers ERR003.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FewIVariables<const N: usize> {
    slots: [(u16, i64); N],
    len: usize,
}

impl<const N: usize> Default for FewIVariables<N> {
    fn default() -> Self {
        FewIVariables { slots: [(0, 0); N], len: 0 }
    }
}

impl<const N: usize> IVariableStore for FewIVariables<N> {
    fn read(&self, n: u16) -> Option<i64> {
        self.slots.iter().take(self.len).find(|(k, _)| *k == n).map(|(_, v)| *v)
    }
    fn forget(&mut self, n: u16) {
        let len = self.len.min(N);
        if let Some(i) = self.slots[..len].iter().position(|(k, _)| *k == n) {
            // The last slot moves into the freed one.
            self.slots[i] = self.slots[len.saturating_sub(1)];
            self.len = len.saturating_sub(1);
        }
    }
    fn write(&mut self, n: u16, v: i64) -> bool {
        let len = self.len.min(N);
        match self.slots[..len].iter().position(|(k, _)| *k == n) {
            Some(i) => self.slots[i].1 = v,
            None if len < N => {
                self.slots[len] = (n, v);
                self.len = len.saturating_add(1);
            }
            None => return false,
        }
        true
    }
    fn factory(&mut self) {
        self.restore();
    }
    fn restore(&mut self) {
        self.len = 0;
    }
}

/// One profile's readings (the profiles of `specs/profiles.yaml`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Profile {
    /// 4095 (SRM p.57) or 4096 (UM p.215).
    pub reset_value_i40_zero: u16,
    pub strobe_stop: StrobeStop,
    /// SRM p.57: the RTI task strobes; UM p.215: the servo interrupt does.
    pub rti_strobes: bool,
    /// M83's reading of bit 12: set only by a firmware checksum error.
    pub bit12_firmware_error: bool,
    /// Bit 9 sticky like bit 22 (otherwise cleared by an RTI whose predecessor finished).
    pub rti_warning_sticky: bool,
    /// UM p.215's encoder-loss PLC clears a latched loss (the intended reading); otherwise
    /// its clear branch is read literally and never clears one.
    pub encoder_loss_clear_intended: bool,
    /// UM p.243: an assignment outside I8's, I40's or I41's range rolls over into it by modulo
    /// arithmetic without an error; otherwise it answers ERR003 and changes nothing (MODEL).
    pub out_of_range_modulo: bool,
}

impl Profile {
    /// The default profile `um-215`.
    pub const UM_215: Profile = Profile {
        reset_value_i40_zero: 4096,
        strobe_stop: StrobeStop::AtZero,
        rti_strobes: false,
        bit12_firmware_error: false,
        rti_warning_sticky: false,
        encoder_loss_clear_intended: true,
        out_of_range_modulo: false,
    };
    /// The profile `srm-57`.
    pub const SRM_57: Profile = Profile {
        reset_value_i40_zero: 4095,
        strobe_stop: StrobeStop::BelowZero,
        rti_strobes: true,
        bit12_firmware_error: false,
        rti_warning_sticky: false,
        encoder_loss_clear_intended: true,
        out_of_range_modulo: false,
    };
}

/// The four DSP56300-family CPU options (SRM p.289), which `???` reports in bits X21 and Y21.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Processor {
    /// Option 5Cx.
    Dsp56303,
    /// Option 5Dx.
    Dsp56309,
    /// Option 5Ex.
    Dsp56311,
    /// Option 5Fx.
    Dsp56321,
}

impl Processor {
    /// X:$000006 and Y:$000006 with the CPU type bits set: bit 1 (X21) for the 56311 and
    /// 56321, bit 0 (Y21) telling each pair apart (SRM p.289).
    pub const fn type_words(self) -> (u32, u32) {
        match self {
            Processor::Dsp56303 => (0, 0),
            Processor::Dsp56309 => (0, bits::CPU_TYPE_0),
            Processor::Dsp56311 => (bits::CPU_TYPE_1, 0),
            Processor::Dsp56321 => (bits::CPU_TYPE_1, bits::CPU_TYPE_0),
        }
    }
}

/// Everything fixed for a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Config {
    pub profile: Profile,
    /// Servo cycles without a strobe edge after which the timer trips.
    pub hardware_delay_cycles: u32,
    pub cycle_units: u16,
    pub servo_units_per_motor: u16,
    pub move_planning_units: u16,
    pub saved_i8: u8,
    pub saved_i40: u16,
    pub saved_i41: u8,
    pub pass_firmware: u8,
    pub pass_user_program: u8,
    /// Supply minimum (UM p.215: about 4.75 V).
    pub supply_min_millivolts: u32,
    /// Mask of X:$000000 (0xFF_FFFF on the card).
    pub servo_counter_mask: u32,
    /// The load at power-up.
    pub load: Load,
    /// The motors, their coordinate systems, and how long a deceleration takes.
    pub motion: MotionConfig,
    /// The CPU option fitted (SRM p.289).
    pub processor: Processor,
    /// A write of an I-variable other than I8, I40, I41 is the card's own (a real card's
    /// range, SRM p.42, UM p.243): not stored, answered [`Reply::CardOwn`]. The emulator
    /// stores every value.
    pub other_i_writes_card_own: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Load {
    pub motors: u8,
    pub plc0_units: u16,
    pub background_units: u16,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Area {
    Firmware,
    UserProgram,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetKind {
    Init,
    Power,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reset {
    pub kind: ResetKind,
    pub dpram_fault: bool,
    pub flash_fault: bool,
    pub bootstrap: bool,
}

/// Registers a host can read with `RH`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Register {
    ServoCycles,
    StatusX,
    StatusY,
    WatchdogCounter,
    WatchdogMinimum,
    RunningChecksum,
    ProgramChecksumReference,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    GlobalStatus,
    ReadI(u16),
    WriteI(u16, i64),
    ReadHex(Register),
    Reset,
    OpenPlc,
    OpenProgram,
    Close,
    /// A command that starts or stops motion (UM p.217, UM p.319; `motion.rs`).
    Motion(MotionCommand),
    /// `$$$***`: reset with the factory-default I-variables (UM p.243).
    Reinitialize,
    /// `CHECKSUM`: the firmware's reference checksum (UM p.217).
    Checksum,
    /// `GATHER`: data gathering starts, X bit 19 (SRM p.289, p.307).
    Gather,
    /// `ENDGATHER`: data gathering stops (SRM p.289, p.307).
    EndGather,
    /// An M-variable assignment or memory write into I-variable `n` (SRM p.57: past I41).
    WriteIMemory(u16, i64),
    /// `I{n}=*`: the factory default (through I41, SRM p.57).
    DefaultI(u16),
    /// A command whose answer is the card's own; the I-variables of `forgets` (first, count,
    /// step) take values this core cannot compute; with `past_lockout` (a memory write or an
    /// M-variable assignment, SRM p.57) those I41 locks too.
    CardOwn {
        forgets: Option<(u16, u16, u16)>,
        past_lockout: bool,
    },
    Unrecognized,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// `n` servo cycles with no background completion, in O(1).
    Servo(u32),
    Background,
    Load(Load),
    Command(Command),
    Supply(u32),
    Reset(Reset),
    ChecksumFault(Area),
    ClearRtiReentry,
    /// Motor `motor`'s (from 1) encoder-loss input changes (UM p.214).
    EncoderInput {
        motor: u8,
        lost: bool,
    },
    /// Motor `motor`'s (from 1) amplifier-fault input changes (UM p.213).
    AmplifierFault {
        motor: u8,
        fault: bool,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reply {
    None,
    Silence,
    Ack,
    Status {
        x: u32,
        y: u32,
    },
    Bootstrap,
    Value(i64),
    Hex(u32),
    Error(u16),
    /// An answer this core has no rule for (the card's own).
    CardOwn,
}

impl Reply {
    /// The 12 characters of a `???` reply (SRM p.289: the first is bits 23-20 of X:$000006).
    pub fn status_text(x: u32, y: u32) -> [u8; 12] {
        const HEX: &[u8; 16] = b"0123456789ABCDEF";
        let mut out = [b'0'; 12];
        for (i, slot) in out.iter_mut().enumerate() {
            let word = if i < 6 { x } else { y };
            let shift = 20u32.saturating_sub(4u32.saturating_mul((i % 6) as u32));
            *slot = HEX[((word >> shift) & 0xF) as usize];
        }
        out
    }
}

/// What can be observed after an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Observation {
    pub reply: Reply,
    /// Red LED, FEFCO/ on, relay over, outputs forced off (UM p.215): all follow the trip.
    pub tripped: bool,
    pub counter: i32,
    pub counter_min: i32,
    pub status_x: u32,
    pub status_y: u32,
}

/// Flags packed in one byte.
const TRIPPED: u8 = 1;
const SUPPLY_LOW: u8 = 2;
const BOOTSTRAP: u8 = 4;
const ERROR_FIRMWARE: u8 = 8;
const ERROR_PROGRAM: u8 = 16;
const AREA_PROGRAM: u8 = 32;

/// The controller state. Equality and hashing are of the representation: a core with quiet
/// servo cycles still deferred (`stretch.rs`) and the same core settled are the same card but
/// unequal values; compare [`Core::settled`] forms (or [`Core::canonical`]) to compare cards.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Core {
    /// Quiet servo cycles taken but not yet applied to the fields below: the servo cycle only
    /// counts them, and [`Self::settle`] applies them at once with [`Self::advance`]'s closed
    /// form. While any are pending, every reader answers as if they had been applied (see
    /// [`Self::quiet_cycles`] for why the readers without a configuration can).
    deferred_cycles: u32,
    /// How many servo cycles may be deferred before the next one has to be taken in full:
    /// the length of the quiet stretch computed after the last full cycle, 0 when none is.
    quiet_cycles_max: u32,
    counter: i32,
    /// The lowest counter value before the current run of decrements. Between two reloads the
    /// counter only falls, so X:$25 (the minimum since reset, SRM p.57) is the smaller of this
    /// and the counter: the servo cycle, the hot path, then has no minimum to keep.
    counter_min_before: i32,
    cycles_since_strobe: u32,
    rti_remaining: u32,
    background_credit: u32,
    servo_cycles: u32,
    /// Wire layout, without bits 12 and 13 (computed from the checksum engine) and bit 20
    /// (`servo_error_shown`).
    status_x: u32,
    status_y: u32,
    load: Load,
    i40: u16,
    rti_phase: u16,
    i8: u8,
    i41: u8,
    flags: u8,
    /// Background cycles done in the current checksum pass.
    position: u8,
    /// Content and reference tokens: bit 0 firmware, 1 firmware reference, 2 program, 3 program reference.
    tokens: u8,
    /// CPU units left after the servo update: it follows from the load, so it is computed
    /// when the load changes, not every cycle.
    free: u32,
    /// 1 when the servo routines do not fit in a servo cycle under the current load (SRM
    /// p.289 bit 20), computed when the load changes.
    servo_overload: u8,
    /// Bit 20 as the last servo cycle left it, 1 or 0: the servo cycle copies one byte.
    servo_error_shown: u8,
    /// The motors and coordinate systems (`motion.rs`).
    motion: motion::Motion,
}

impl Core {
    pub fn power_on(cfg: &Config) -> Core {
        let mut c = Core {
            deferred_cycles: 0,
            quiet_cycles_max: 0,
            counter: 0,
            counter_min_before: 0,
            cycles_since_strobe: 0,
            rti_remaining: 0,
            background_credit: 0,
            servo_cycles: 0,
            status_x: 0,
            status_y: 0,
            load: cfg.load,
            i40: 0,
            rti_phase: 0,
            i8: 0,
            i41: 0,
            flags: 0,
            position: 0,
            tokens: 0,
            free: 0,
            servo_overload: 0,
            servo_error_shown: 0,
            motion: motion::Motion::power_on(),
        };
        c.set_load(cfg, cfg.load);
        c.restart(cfg, Reset { kind: ResetKind::Power, dpram_fault: false, flash_fault: false, bootstrap: false });
        c
    }

    pub fn tripped(&self) -> bool {
        self.flags & TRIPPED != 0
    }

    /// Whether the card is in bootstrap mode (a reset found the bootstrap jumper, SRM p.289):
    /// it runs no servo, RTI or background tasks.
    pub fn bootstrap(&self) -> bool {
        self.flags & BOOTSTRAP != 0
    }

    fn running(&self) -> bool {
        self.flags & (TRIPPED | BOOTSTRAP) == 0
    }

    /// The CPU load the card runs under now.
    pub fn load(&self) -> Load {
        self.load
    }

    /// CPU units a servo cycle leaves after the servo update, for the RTI and the background
    /// (kept up to date by every load change).
    pub fn spare_units(&self) -> u32 {
        self.free
    }

    pub fn counter(&self) -> i32 {
        // A quiet stretch ends before the counter would go below zero, so each deferred cycle
        // took exactly one off it under both readings of `strobe_stop` (`quiet_cycles`), and
        // the subtraction cannot wrap.
        self.counter.wrapping_sub_unsigned(self.deferred_cycles)
    }

    /// X:$25, the lowest counter value since reset (SRM p.57).
    pub fn counter_min(&self) -> i32 {
        self.counter_min_before.min(self.counter())
    }

    /// This state settled twice over: its deferred servo cycles applied ([`Self::settled`]), and
    /// the lazily kept minimum settled, the minimum before the current run of decrements
    /// replaced by X:$25 itself. The two behave the same under every event (the
    /// minimum is read only as X:$25, and folded into itself at a reload; a reset replaces it),
    /// so a search over core states (the exhaustive lockstep) identifies them by this form:
    /// otherwise each value of the settled minimum would count as a state of its own.
    pub fn canonical(&self, cfg: &Config) -> Core {
        let c = self.settled(cfg);
        Core { counter_min_before: c.counter_min(), ..c }
    }

    /// Motor `n` (from 1) as a host or an instrument sees it: state, stop under way, amplifier
    /// enable, commanded output, encoder input, the PLC's latched loss, its coordinate system
    /// and that system's program; `None` for a motor the configuration does not have.
    pub fn motor(&self, cfg: &Config, n: u8) -> Option<MotorStatus> {
        self.motion().motor(&cfg.motion, n)
    }

    /// The motors and coordinate systems (with the deferred cycles counted off the stops
    /// under way: no stop ends within a quiet stretch).
    pub fn motion(&self) -> motion::Motion {
        self.motion.counted_down(self.deferred_cycles)
    }

    pub fn background_possible(&self) -> bool {
        self.running() && self.background_credit >= u32::from(self.load.background_units)
    }

    /// X:$000006 and Y:$000006 as `???` reports them.
    pub fn status_words(&self, cfg: &Config) -> (u32, u32) {
        if self.deferred_cycles != 0 {
            // The RTI's bits may have changed in the deferred cycles.
            return self.settled(cfg).status_words(cfg);
        }
        let mut x = self.status_x | if self.servo_error_shown != 0 { bits::SERVO_ERROR } else { 0 };
        let error = self.flags & (ERROR_FIRMWARE | ERROR_PROGRAM);
        if error != 0 {
            x |= bits::CHECKSUM_ERROR;
        }
        // SRM p.289: 1 while evaluating the firmware (13 = 0) or after a firmware error; under
        // the M83 reading only after a firmware error.
        let bit12 = if cfg.profile.bit12_firmware_error || error != 0 {
            error == ERROR_FIRMWARE
        } else {
            self.flags & AREA_PROGRAM == 0
        };
        if bit12 {
            x |= bits::PROM_CHECKSUM_ACTIVE;
        }
        // SRM p.289: bits X21 and Y21 are the CPU option fitted.
        let (cpu_x, cpu_y) = cfg.processor.type_words();
        (x | cpu_x, self.status_y | cpu_y)
    }

    pub fn observe(&self, cfg: &Config, reply: Reply) -> Observation {
        if self.deferred_cycles != 0 {
            return self.settled(cfg).observe(cfg, reply);
        }
        let (status_x, status_y) = self.status_words(cfg);
        Observation {
            reply,
            tripped: self.tripped(),
            counter: self.counter,
            counter_min: self.counter_min(),
            status_x,
            status_y,
        }
    }

    /// Applies one event and returns the reply. `store` holds the I-variables the core does not
    /// read itself (see [`IVariableStore`]); only host commands and resets touch it.
    pub fn apply<S: IVariableStore + ?Sized>(&mut self, cfg: &Config, event: Event, store: &mut S) -> Reply {
        // Every event but a servo cycle applies to the card as it stands: deferred cycles first.
        self.settle(cfg);
        match event {
            Event::Servo(n) => {
                self.advance(cfg, n);
                Reply::None
            }
            Event::Background => {
                self.background_cycle(cfg);
                Reply::None
            }
            Event::Load(l) => {
                self.set_load(cfg, l);
                Reply::None
            }
            Event::Command(c) => self.command(cfg, c, store),
            Event::Supply(mv) => {
                // UM p.215: below about 4.75 V the relay trips and the card shuts down.
                if mv < cfg.supply_min_millivolts {
                    self.flags |= SUPPLY_LOW;
                    self.trip();
                } else {
                    self.flags &= !SUPPLY_LOW;
                }
                Reply::None
            }
            Event::Reset(r) => {
                if r.kind == ResetKind::Power {
                    self.flags &= !SUPPLY_LOW;
                }
                let low = self.flags & SUPPLY_LOW;
                // UM p.215: only a power cycle or an INIT/ pulse undoes a trip.
                self.restart(cfg, r);
                store.restore();
                if low != 0 {
                    self.flags |= SUPPLY_LOW;
                    self.trip();
                }
                Reply::None
            }
            Event::ChecksumFault(area) => {
                if !self.tripped() {
                    self.tokens ^= match area {
                        Area::Firmware => 1,
                        Area::UserProgram => 4,
                    };
                }
                Reply::None
            }
            Event::ClearRtiReentry => {
                // SRM p.289: bit 22 stays set "until this bit is manually changed to 0".
                if !self.tripped() {
                    self.status_x &= !bits::RTI_REENTRY;
                }
                Reply::None
            }
            Event::EncoderInput { motor, lost } => {
                // UM p.214: a hardware input, which changes whether or not the card runs.
                self.motion.encoder_input(&cfg.motion, motor, lost);
                Reply::None
            }
            Event::AmplifierFault { motor, fault } => {
                // UM p.213: the amplifier-fault line, a hardware input.
                self.motion.amplifier_fault_input(&cfg.motion, motor, fault);
                Reply::None
            }
        }
    }

    fn restart(&mut self, cfg: &Config, r: Reset) {
        self.restart_with(cfg, r, (cfg.saved_i8, cfg.saved_i40, cfg.saved_i41));
    }

    /// [`Self::restart`] with I8, I40, I41 = `i_variables`: the saved values, or the factory
    /// defaults after `$$$***` (UM p.243).
    fn restart_with(&mut self, cfg: &Config, r: Reset, i_variables: (u8, u16, u8)) {
        let supply_low = self.flags & SUPPLY_LOW;
        self.flags = supply_low | if r.bootstrap { BOOTSTRAP } else { 0 };
        (self.i8, self.i40, self.i41) = i_variables;
        self.counter = counter::reset_value(self.i40, cfg.profile.reset_value_i40_zero);
        self.counter_min_before = self.counter;
        self.cycles_since_strobe = 0;
        self.rti_phase = 0;
        self.rti_remaining = 0;
        self.background_credit = 0;
        // SRM p.289: bits 11 and 10 report the reset-time DPRAM check and flash read.
        self.status_x =
            (if r.dpram_fault { bits::DPRAM_ERROR } else { 0 }) | (if r.flash_fault { bits::FLASH_ERROR } else { 0 });
        self.status_y = 0;
        self.servo_error_shown = 0;
        self.position = 0;
        // MODEL, as the reference model: a reset does not rewrite PROM or flash, so the
        // contents and references (`tokens`) keep any corruption; the engine starts over.
        self.servo_cycles = 0;
        // UM p.215: a reset restores "normal functioning"; the motors start as at power-up.
        self.motion.restart();
    }

    /// UM p.215: "the system is latched into a reset state"; the ICs held in reset force the
    /// outputs off, so every amplifier is disabled and every motor reads killed.
    fn trip(&mut self) {
        self.flags |= TRIPPED;
        self.motion.force_off();
    }

    // ------------------------------------------------------------------ foreground

    /// The RTI bookkeeping of one servo cycle, given the CPU `free` after the servo update.
    /// Returns the tick and the units left to the background.
    #[inline]
    fn rti_cycle(&mut self, cfg: &Config, free: u32) -> (Tick, u32) {
        // UM p.236: the RTI runs every I8+1 servo cycles.
        let due = self.rti_phase >= u16::from(self.i8);
        if !due && self.rti_remaining == 0 {
            // Between ticks with the RTI's work done, the most common servo cycle: all of `free`
            // goes to the background. (The general path below gives the same; this one skips
            // its arithmetic: measured, 3 of the idle servo cycle's 56.7 instructions.)
            self.rti_phase = self.rti_phase.wrapping_add(1);
            return (Tick::None, free);
        }
        self.rti_phase = if due { 0 } else { self.rti_phase.saturating_add(1) };
        let mut tick = Tick::None;
        if due {
            if self.rti_remaining > 0 {
                // SRM p.289-290: bits 22 and 9; UM p.236: PLC 0 not restarted.
                self.status_x |= bits::RTI_REENTRY | bits::RTI_WARNING;
                tick = Tick::Overrun;
            } else {
                if !cfg.profile.rti_warning_sticky {
                    self.status_x &= !bits::RTI_WARNING;
                }
                // UM p.236: the planning of the next move runs at the RTI while a program
                // executes moves (MODEL, as the reference model: one new move per RTI period).
                self.rti_remaining = u32::from(self.load.plc0_units).saturating_add(self.planning_units(cfg));
                tick = Tick::Started;
            }
        }
        let work = free.min(self.rti_remaining);
        // `work` is the smaller of the two, so neither subtraction can wrap: the plain forms
        // cost the servo cycle two instructions fewer than saturating ones would.
        self.rti_remaining = self.rti_remaining.wrapping_sub(work);
        (tick, free.wrapping_sub(work))
    }

    /// The move planning an RTI runs (UM p.236): `cfg.move_planning_units` while a program
    /// executes moves, none otherwise.
    fn planning_units(&self, cfg: &Config) -> u32 {
        if self.motion.plans_moves() {
            u32::from(cfg.move_planning_units)
        } else {
            0
        }
    }

    fn set_load(&mut self, cfg: &Config, load: Load) {
        self.load = load;
        // UM p.236: the servo update takes about 1% of the cycle a motor.
        let servo = u32::from(load.motors).saturating_mul(u32::from(cfg.servo_units_per_motor));
        // SRM p.289 bit 20: the servo routines could not complete.
        self.servo_overload = u8::from(servo > u32::from(cfg.cycle_units));
        self.free = u32::from(cfg.cycle_units).saturating_sub(servo);
    }

    /// Bit 20 as of this servo cycle, and the CPU units the cycle leaves.
    #[inline]
    fn free_units(&mut self) -> u32 {
        self.servo_error_shown = self.servo_overload;
        self.free
    }

    /// One servo interrupt and its RTI on a settled card.
    #[inline(always)]
    fn step(&mut self, cfg: &Config) {
        if !self.running() {
            return;
        }
        self.servo_cycles = self.servo_cycles.wrapping_add(1) & cfg.servo_counter_mask;
        let free = self.free_units();
        // The stops under way advance one servo cycle (`motion.rs`); one byte read when none is.
        self.motion.servo_cycles(&cfg.motion, 1);
        let (counter, allowed) = counter::decrement(self.counter, cfg.profile.strobe_stop);
        self.counter = counter;
        let tick = self.credit_cycle(cfg, free);
        let strobe = allowed && (!cfg.profile.rti_strobes || tick != Tick::None);
        if strobe {
            self.cycles_since_strobe = 0;
        } else {
            // UM p.215: no strobe edge for longer than the hardware allows: trip. The gap this
            // cycle makes is one more than the gap before it, so it exceeds the delay exactly
            // when the gap before has reached it; compared before the count, which saturates,
            // so that a delay of u32::MAX trips when `advance` says, not never.
            let trips = self.cycles_since_strobe >= cfg.hardware_delay_cycles;
            self.cycles_since_strobe = self.cycles_since_strobe.saturating_add(1);
            if trips {
                self.trip();
            }
        }
    }

    /// The RTI period, I8 + 1 servo cycles (UM p.236), and the first of the next cycles
    /// (counting from 1) on which the RTI runs.
    fn rti_schedule(&self) -> (u32, u32) {
        let i8 = u32::from(self.i8);
        let phase = u32::from(self.rti_phase);
        let first = if phase >= i8 { 1 } else { i8.saturating_sub(phase).saturating_add(1) };
        (i8.saturating_add(1), first)
    }

    /// The last of the next `bound` cycles that strobes, if any: every one (UM p.215: the servo
    /// interrupt strobes), or only the RTI ticks when the profile has the RTI task strobe
    /// (SRM p.57).
    fn last_strobe_within(&self, cfg: &Config, bound: u32) -> Option<u32> {
        if !cfg.profile.rti_strobes {
            return (bound > 0).then_some(bound);
        }
        let (period, first) = self.rti_schedule();
        (first <= bound).then(|| {
            first.saturating_add(bound.saturating_sub(first).checked_div(period).unwrap_or(0).saturating_mul(period))
        })
    }

    /// The first of the next servo cycles at which the timer trips, in closed form.
    fn trip_cycle(&self, cfg: &Config) -> u64 {
        let delay = u64::from(cfg.hardware_delay_cycles);
        let gap = u64::from(self.cycles_since_strobe);
        // UM p.215: the timer trips once no strobe edge has come for longer than the delay.
        let trip_after = |strobe: u32| u64::from(strobe).saturating_add(delay).saturating_add(1);
        let unstrobed = delay.saturating_add(1).saturating_sub(gap).max(1);
        // Strobes may come only while the counter allows them: cycles 1..=allowed.
        let allowed = counter::strobing_cycles(self.counter);
        if cfg.profile.rti_strobes {
            // Only RTI ticks strobe (SRM p.57). A tick zeroes the phase and a strobe the gap, so
            // the gap is never shorter than the phase, and a running card's gap is at most the
            // delay. Hence a next tick inside the unstrobed window means a period of at most
            // delay + 1 cycles: every tick the counter allows strobes in time, and the trip
            // comes after the last of them (below). A tick beyond the window is never reached.
            let (_, first) = self.rti_schedule();
            if u64::from(first) > unstrobed {
                return unstrobed;
            }
        }
        self.last_strobe_within(cfg, allowed).map_or(unstrobed, trip_after)
    }

    /// `n` servo cycles with no background completion, in constant time: the counter, its
    /// minimum, the strobe gap and the trip in closed form; the RTI over whole periods in
    /// closed form, with at most two partial periods stepped.
    pub fn advance(&mut self, cfg: &Config, n: u32) {
        self.settle(cfg);
        self.advance_settled(cfg, n);
    }

    /// [`Self::advance`] on a settled card.
    fn advance_settled(&mut self, cfg: &Config, n: u32) {
        if !self.running() || n == 0 {
            return;
        }
        // Up to the trip, if it comes within the n cycles: a tripped card stops.
        let trip_at = self.trip_cycle(cfg);
        let trips = trip_at <= u64::from(n);
        let k = if trips { u32::try_from(trip_at).unwrap_or(n) } else { n };
        // Counter, minimum, strobe gap.
        let allowed = counter::strobing_cycles(self.counter);
        let last_strobe = self.last_strobe_within(cfg, allowed.min(k));
        self.counter = counter::after(self.counter, k, cfg.profile.strobe_stop);
        self.cycles_since_strobe = match last_strobe {
            Some(s) => k.saturating_sub(s),
            None => self.cycles_since_strobe.saturating_add(k),
        };
        self.servo_cycles = (self.servo_cycles.wrapping_add(k)) & cfg.servo_counter_mask;
        // RTI and background credit.
        let free = self.free_units();
        let mut remaining_cycles = k;
        let period = u32::from(self.i8).saturating_add(1);
        // Step to the first RTI tick (the next cycle is a tick when phase >= I8).
        while remaining_cycles > 0 && self.rti_phase < u16::from(self.i8) {
            self.credit_cycle(cfg, free);
            remaining_cycles = remaining_cycles.saturating_sub(1);
        }
        if self.rti_phase > u16::from(self.i8) && remaining_cycles > 0 {
            self.credit_cycle(cfg, free);
            remaining_cycles = remaining_cycles.saturating_sub(1);
            while remaining_cycles > 0 && self.rti_phase < u16::from(self.i8) {
                self.credit_cycle(cfg, free);
                remaining_cycles = remaining_cycles.saturating_sub(1);
            }
        }
        let whole = remaining_cycles.checked_div(period).unwrap_or(0);
        if whole > 0 {
            // A program executes moves or not for the whole of the k cycles: servo cycles end
            // only stops, which never start a program's moves (`Motion::plans_moves`).
            let task = u64::from(self.load.plc0_units).saturating_add(u64::from(self.planning_units(cfg)));
            let p = rti::whole_periods(
                u64::from(self.rti_remaining),
                u64::from(whole),
                u64::from(period),
                u64::from(free),
                task,
            );
            self.rti_remaining = u32::try_from(p.remaining).unwrap_or(u32::MAX);
            if p.any_overrun {
                self.status_x |= bits::RTI_REENTRY | bits::RTI_WARNING;
            }
            if !cfg.profile.rti_warning_sticky {
                match p.last {
                    Tick::Overrun => self.status_x |= bits::RTI_WARNING,
                    Tick::Started => self.status_x &= !bits::RTI_WARNING,
                    Tick::None => {}
                }
            }
            let cap = u64::from(self.load.background_units);
            self.background_credit =
                u32::try_from(u64::from(self.background_credit).saturating_add(p.share).min(cap)).unwrap_or(0);
            // A whole number of periods ends where it started: due again.
            remaining_cycles = remaining_cycles.saturating_sub(whole.saturating_mul(period));
        }
        while remaining_cycles > 0 {
            self.credit_cycle(cfg, free);
            remaining_cycles = remaining_cycles.saturating_sub(1);
        }
        // The stops under way, over the same k cycles (the trip cycle's motion comes before
        // the trip, as in a single servo cycle).
        self.motion.servo_cycles(&cfg.motion, k);
        if trips {
            self.trip();
        }
    }

    /// One cycle's RTI bookkeeping and the background credit it leaves; returns the RTI tick.
    #[inline]
    fn credit_cycle(&mut self, cfg: &Config, free: u32) -> Tick {
        let (tick, left) = self.rti_cycle(cfg, free);
        // Both terms are below 2^17 (the credit is capped by a u16, `left` is at most the
        // cycle's u16 units), so the sum cannot wrap.
        self.background_credit = self.background_credit.wrapping_add(left).min(u32::from(self.load.background_units));
        tick
    }

    // ------------------------------------------------------------------ background

    pub fn background_cycle(&mut self, cfg: &Config) {
        self.settle(cfg);
        if !self.background_possible() {
            return;
        }
        self.background_credit = 0;
        // The run of decrements ends here: its lowest value, the counter now, joins the minimum
        // (the card is settled: the counter field is the counter).
        self.counter_min_before = self.counter_min_before.min(self.counter);
        // UM p.215: "At the end of each background cycle, the CPU resets the counter".
        self.counter = counter::reset_value(self.i40, cfg.profile.reset_value_i40_zero);
        self.checksum_step(cfg);
        // UM p.215: the safety PLCs scan once per background cycle, after the checksum step
        // (the order of the reference model; neither reads what the other writes).
        self.motion.encoder_loss_plc(&cfg.motion, cfg.profile.encoder_loss_clear_intended);
        // UM p.237: the housekeeping's safety checks end the cycle; UM p.213: an amplifier
        // fault kills the offending motor (the firmware's rule, after the PLC's scan).
        self.motion.amplifier_fault_check(&cfg.motion);
    }

    /// One background step of the checksum engine.
    fn checksum_step(&mut self, cfg: &Config) {
        // UM p.217: the checksums run in background and stop for good on a mismatch.
        if self.flags & (ERROR_FIRMWARE | ERROR_PROGRAM) != 0 {
            return;
        }
        self.position = self.position.saturating_add(1);
        let program = self.flags & AREA_PROGRAM != 0;
        let pass = if program { cfg.pass_user_program } else { cfg.pass_firmware };
        if self.position < pass {
            return;
        }
        let (content, reference) = if program {
            (self.tokens >> 2 & 1, self.tokens >> 3 & 1)
        } else {
            (self.tokens & 1, self.tokens >> 1 & 1)
        };
        if content != reference {
            self.flags |= if program { ERROR_PROGRAM } else { ERROR_FIRMWARE };
        } else {
            self.position = 0;
            self.flags ^= AREA_PROGRAM;
        }
    }

    // ------------------------------------------------------------------ host commands

    pub fn command<S: IVariableStore + ?Sized>(&mut self, cfg: &Config, c: Command, store: &mut S) -> Reply {
        self.settle(cfg);
        // UM p.215: a tripped card will not communicate.
        if self.tripped() {
            return Reply::Silence;
        }
        if self.flags & BOOTSTRAP != 0 {
            // SRM p.289: BOOTSTRAP PROM.
            return if c == Command::GlobalStatus { Reply::Bootstrap } else { Reply::Error(3) };
        }
        match c {
            Command::GlobalStatus => {
                let (x, y) = self.status_words(cfg);
                Reply::Status { x, y }
            }
            Command::ReadI(n) => self.read_i(n, store).map_or(Reply::CardOwn, Reply::Value),
            Command::WriteI(n, v) => self.write_i(cfg, n, v, store),
            Command::ReadHex(r) => Reply::Hex(self.register(cfg, r)),
            Command::Reset => {
                self.restart(
                    cfg,
                    Reset { kind: ResetKind::Init, dpram_fault: false, flash_fault: false, bootstrap: false },
                );
                store.restore();
                Reply::None
            }
            Command::OpenPlc => {
                self.status_y |= bits::PLC_BUFFER_OPEN;
                Reply::Ack
            }
            Command::OpenProgram => {
                self.status_y |= bits::MOTION_BUFFER_OPEN;
                Reply::Ack
            }
            Command::Close => {
                self.status_y &= !(bits::PLC_BUFFER_OPEN | bits::MOTION_BUFFER_OPEN);
                // UM p.217: X:$1090 takes the checksum computed when a buffer is closed.
                self.tokens = (self.tokens & !8) | ((self.tokens & 4) << 1);
                Reply::Ack
            }
            // UM p.217, UM p.319 (`motion.rs`); ERR001, Turbo PMAC's "command not allowed
            // during program execution", for a K the program refuses (as the reference model).
            Command::Motion(m) => match self.motion.command(&cfg.motion, m) {
                motion::Outcome::Accepted => Reply::Ack,
                motion::Outcome::RefusedDuringProgram => Reply::Error(1),
            },
            Command::Reinitialize => {
                // UM p.243: the factory defaults in active memory, the saved values unused.
                self.restart_with(
                    cfg,
                    Reset { kind: ResetKind::Init, dpram_fault: false, flash_fault: false, bootstrap: false },
                    (I8_DEFAULT, I40_DEFAULT, I41_DEFAULT),
                );
                store.factory();
                Reply::None
            }
            // UM p.217: the reference register, preloaded at the factory (token 0, MODEL as
            // the reference model: no memory is summed).
            Command::Checksum => Reply::Hex(u32::from(self.tokens >> 1 & 1)),
            // SRM p.289: bit 19 while the data gathering function is active; SRM p.307: until
            // ENDGATHER (MODEL, as the reference model: the buffer never fills; a reset ends it,
            // `restart_with` clearing the word).
            Command::Gather => {
                self.status_x |= bits::DATA_GATHERING_ON;
                Reply::Ack
            }
            Command::EndGather => {
                self.status_x &= !bits::DATA_GATHERING_ON;
                Reply::Ack
            }
            // SRM p.57: I41 does not stop an M-variable assignment or a memory write.
            Command::WriteIMemory(n, v) => self.store_i(cfg, n, v, store),
            // As the reference model: the defaults of I8, I40, I41 are the core's; any other
            // I-variable becomes unknown, unless I41 locks it (SRM p.57).
            Command::DefaultI(n) => match n {
                8 => self.write_i(cfg, 8, i64::from(I8_DEFAULT), store),
                40 => self.write_i(cfg, 40, i64::from(I40_DEFAULT), store),
                41 => self.write_i(cfg, 41, i64::from(I41_DEFAULT), store),
                n => {
                    if !self.write_locked(n) {
                        store.forget(n);
                    }
                    Reply::Ack
                }
            },
            // SRM p.57: I41 does not prevent a memory write or an M-variable assignment
            // (`past_lockout`); an I-variable write to a locked variable is ignored.
            Command::CardOwn { forgets, past_lockout } => {
                if let Some((first, count, step)) = forgets {
                    for k in 0..count {
                        let n = first.saturating_add(k.saturating_mul(step));
                        if past_lockout || !self.write_locked(n) {
                            store.forget(n);
                        }
                    }
                }
                Reply::CardOwn
            }
            Command::Unrecognized => Reply::Error(3),
        }
    }

    /// Whether I41 locks I`n` against host writes now (SRM p.57: the write is then ignored).
    pub fn write_locked(&self, n: u16) -> bool {
        LOCKOUT.iter().position(|(a, b)| (*a..=*b).contains(&n)).is_some_and(|bit| self.i41 & (1u8 << bit) != 0)
    }

    pub fn read_i<S: IVariableStore + ?Sized>(&self, n: u16, store: &S) -> Option<i64> {
        match n {
            8 => Some(i64::from(self.i8)),
            40 => Some(i64::from(self.i40)),
            41 => Some(i64::from(self.i41)),
            _ => store.read(n),
        }
    }

    /// An I-variable write. Locked writes are ignored without an error (SRM p.57). Values
    /// outside I8's, I40's or I41's range answer ERR003 (MODEL, as the reference model), or
    /// roll over into it under [`Profile::out_of_range_modulo`] (UM p.243); a write the store
    /// has no room for answers ERR003 (a limit of the store, not of the card).
    fn write_i<S: IVariableStore + ?Sized>(&mut self, cfg: &Config, n: u16, v: i64, store: &mut S) -> Reply {
        if self.write_locked(n) {
            return Reply::Ack;
        }
        self.store_i(cfg, n, v, store)
    }

    /// I`n` = `v` whatever I41 holds (past the lockout, or by a memory write, SRM p.57).
    fn store_i<S: IVariableStore + ?Sized>(&mut self, cfg: &Config, n: u16, v: i64, store: &mut S) -> Reply {
        // UM p.243: "rolled over to within the range by modulo arithmetic (truncation)"; each
        // range starts at 0 and holds a power of two values, so the roll-over keeps the low
        // bits (I3=5 gives 1 of 0..3).
        let modulo = cfg.profile.out_of_range_modulo;
        match n {
            8 if (0..=I8_MAX).contains(&v) => self.i8 = v as u8,
            40 if (0..=I40_MAX).contains(&v) => self.i40 = v as u16,
            41 if (0..=I41_MAX).contains(&v) => self.i41 = v as u8,
            8 if modulo => self.i8 = v.rem_euclid(I8_MAX + 1) as u8,
            40 if modulo => self.i40 = v.rem_euclid(I40_MAX + 1) as u16,
            41 if modulo => self.i41 = v.rem_euclid(I41_MAX + 1) as u8,
            8 | 40 | 41 => return Reply::Error(3),
            _ if cfg.other_i_writes_card_own => {
                store.forget(n);
                return Reply::CardOwn;
            }
            _ if store.write(n, v) => {}
            _ => return Reply::Error(3),
        }
        Reply::Ack
    }

    pub fn register(&self, cfg: &Config, r: Register) -> u32 {
        if self.deferred_cycles != 0 {
            return self.settled(cfg).register(cfg, r);
        }
        let word = |v: i32| (v as u32) & 0xFF_FFFF;
        match r {
            Register::ServoCycles => self.servo_cycles,
            Register::StatusX => self.status_words(cfg).0,
            Register::StatusY => self.status_words(cfg).1,
            Register::WatchdogCounter => word(self.counter),
            Register::WatchdogMinimum => word(self.counter_min()),
            Register::RunningChecksum => (u32::from(self.flags & AREA_PROGRAM != 0) << 8) | u32::from(self.position),
            Register::ProgramChecksumReference => u32::from(self.tokens >> 3 & 1),
        }
    }
}
