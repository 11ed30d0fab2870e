//! The simulated wafer cell on the simulated board: [`SimCell`] keeps a [`wrc_cell::World`]
//! as the ground truth and plays the hand's sensors from it. Every board period
//! ([`SimCell::step`]) it turns the axes' encoder positions into the hand's pose (pulses →
//! joints → forward kinematics), steps the world with the vacuum valve output, and runs the
//! mapping sensor. A step does not block or make system calls, and allocates only when the
//! world records a lost wafer (a fault).
//!
//! A dual-blade robot's blade B (`[hand.blade_b]`) is stepped in the world too, at the hand's
//! pose raised by its `z_offset_mm`, with its own vacuum valve; its sensor follows its wafer.
//!
//! The mapping sensor is on while the hand's `mapping_output` is on. While it is on, the
//! hand faces a station when its x, y are within [`SEAT_TOLERANCE_MM`] of the station's
//! approach point and its yaw within [`SEAT_TOLERANCE_DEG`] of the station's yaw; then every
//! slot whose support height lies between the previous period's hand z and this period's
//! (either direction, both ends included) is latched with its [`wrc_cell::SlotCode`]. Facing
//! another station than the latched one clears the latch first. The host clears it with
//! [`SimCell::clear_latch`] (through the DPRAM's `CLEAR_SEQ`).

use wrc_cell::{
    Blade, SlotCode, StationName, Stations, StationsError, World, WorldEvent, SEAT_TOLERANCE_DEG,
    SEAT_TOLERANCE_MM,
};
use wrc_config::{BoardConfig, Config, HandConfig};
use wrc_robot::{wrap180, Pose, Robot, MAX_AXES};

use wrc_board::dpram::MappingRecord;
use wrc_board::layout::{mapping, slot_code, AXES_PER_BOARD};

/// Why the cell cannot be simulated on a board.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CellError {
    /// Some robot axes are on other boards, so this board cannot know the hand's pose.
    #[error(
        "the simulated cell needs every robot axis on one board, but board {board} does not \
         drive {missing}; put all axes on board {board} or simulate the board without the cell \
         (leave out --stations)"
    )]
    AxesElsewhere {
        /// The board.
        board: u32,
        /// The robot axes it does not drive, comma-separated.
        missing: String,
    },
    /// The stations are unusable or out of the robot's reach (in the message, so not also
    /// a `source`).
    #[error("the simulated cell's stations: {0}")]
    Stations(StationsError),
}

impl From<StationsError> for CellError {
    fn from(e: StationsError) -> Self {
        CellError::Stations(e)
    }
}

/// Where the mapping sensor faces one station: its approach point and slot heights.
#[derive(Debug, Clone, Copy)]
struct Face {
    name: StationName,
    /// Approach point x, y \[mm\] (the same for every slot) and the station's yaw \[deg\].
    x: f64,
    y: f64,
    yaw: f64,
    /// Support height of slot 1 \[mm\] and the pitch \[mm\].
    z1: f64,
    pitch: f64,
    slots: u16,
}

impl Face {
    fn faced_by(&self, pose: &Pose) -> bool {
        (pose.x - self.x).hypot(pose.y - self.y) <= SEAT_TOLERANCE_MM
            && wrap180(pose.yaw - self.yaw).abs() <= SEAT_TOLERANCE_DEG
    }
}

/// The 2-bit DPRAM code of a slot code ([`slot_code`]).
pub fn code_bits(code: SlotCode) -> u32 {
    match code {
        SlotCode::Absent => slot_code::ABSENT,
        SlotCode::Present => slot_code::PRESENT,
        SlotCode::Double => slot_code::DOUBLE,
        SlotCode::Cross => slot_code::CROSS,
    }
}

/// The simulated cell of one board (see the module docs).
#[derive(Debug, Clone)]
pub struct SimCell {
    world: World,
    stations: Stations,
    robot: Robot,
    /// Board channel of each robot axis, in robot axis order.
    channels: [usize; MAX_AXES],
    axis_count: usize,
    hand: HandConfig,
    faces: Vec<Face>,
    pose: Pose,
    previous_z: Option<f64>,
    latch: MappingRecord,
    latch_changed: bool,
    last_event: Option<WorldEvent>,
    events: u64,
}

impl SimCell {
    /// The cell of `stations` on `board` of `config`, with the wafers of the stations'
    /// `[station.sim]` tables ([`World::new`]). Every robot axis must be on `board`, and
    /// the stations must pass [`Stations::validate`] against the robot.
    pub fn new(
        config: &Config,
        board: &BoardConfig,
        stations: Stations,
    ) -> Result<SimCell, CellError> {
        let robot = &config.robot;
        let mut channels = [0usize; MAX_AXES];
        let mut missing = Vec::new();
        for (axis, a) in robot.axes().iter().enumerate() {
            match board.axes.iter().position(|&i| i == axis) {
                Some(channel) if channel < AXES_PER_BOARD => channels[axis] = channel,
                _ => missing.push(a.name.as_str().to_string()),
            }
        }
        if !missing.is_empty() {
            return Err(CellError::AxesElsewhere {
                board: board.id,
                missing: missing.join(", "),
            });
        }
        stations.validate(robot)?;
        let faces = stations
            .iter()
            .map(|s| {
                // Slot 1 exists in every checked station; the approach x, y are the same for
                // every slot.
                let approach = s.approach_pose(1, false).unwrap_or(s.pose);
                Face {
                    name: s.name,
                    x: approach.x,
                    y: approach.y,
                    yaw: s.pose.yaw,
                    z1: s.pose.z,
                    pitch: s.pitch_mm,
                    slots: s.slots.min(mapping::MAX_SLOTS as u16),
                }
            })
            .collect();
        let mut world = World::new(&stations);
        let offsets: Vec<f64> = std::iter::once(0.0)
            .chain(config.hand.blade_b.map(|b| b.z_offset_mm))
            .collect();
        world.set_arm(robot, &stations, &offsets);
        Ok(SimCell {
            world,
            stations,
            robot: robot.clone(),
            channels,
            axis_count: robot.axis_count(),
            hand: config.hand,
            faces,
            pose: Pose::default(),
            previous_z: None,
            latch: MappingRecord::default(),
            latch_changed: false,
            last_event: None,
            events: 0,
        })
    }

    /// The same cell starting from `world` instead, e.g. read back with
    /// [`World::from_text`] and this cell's [`SimCell::stations`].
    pub fn with_world(self, mut world: World) -> SimCell {
        let offsets: Vec<f64> = std::iter::once(0.0)
            .chain(self.hand.blade_b.map(|b| b.z_offset_mm))
            .collect();
        world.set_arm(&self.robot, &self.stations, &offsets);
        SimCell { world, ..self }
    }

    /// The ground truth.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The stations, in stations-file order (the mapping latch's station numbers).
    pub fn stations(&self) -> &Stations {
        &self.stations
    }

    /// The hand's signals it reacts to.
    pub fn hand(&self) -> &HandConfig {
        &self.hand
    }

    /// The hand's pose at the last step (forward kinematics of the encoders).
    pub fn pose(&self) -> Pose {
        self.pose
    }

    /// The mapping latch as it stands.
    pub fn latch(&self) -> &MappingRecord {
        &self.latch
    }

    /// World events so far (picks, places and faults): a change counter.
    pub fn events(&self) -> u64 {
        self.events
    }

    /// Whether a wafer is on the hand (the vacuum sensor needs it).
    pub fn wafer_on_hand(&self) -> bool {
        self.world.hand().is_some()
    }

    /// Whether a wafer is on `blade`.
    pub fn wafer_on(&self, blade: Blade) -> bool {
        self.world.hand_of(blade).is_some()
    }

    /// The world event of the last step that had one, once: the board's log prints it
    /// outside the real-time step.
    pub fn take_event(&mut self) -> Option<WorldEvent> {
        self.last_event.take()
    }

    /// Clear the mapping latch (a new scan starts).
    pub fn clear_latch(&mut self) {
        self.latch = MappingRecord::default();
        self.latch_changed = true;
    }

    /// The latch, once after each change (to publish it).
    pub fn take_latch_change(&mut self) -> Option<MappingRecord> {
        std::mem::take(&mut self.latch_changed).then_some(self.latch)
    }

    /// One board period: `encoders` are the board's encoder positions in channel order
    /// \[pulse\], `outputs` the digital outputs the board drives.
    pub fn step(&mut self, encoders: &[i64; AXES_PER_BOARD], outputs: u32) {
        let mut pulses = [0i64; MAX_AXES];
        for (p, &channel) in pulses.iter_mut().zip(&self.channels).take(self.axis_count) {
            *p = encoders[channel];
        }
        let joints = self.robot.pulses_to_joints(&pulses);
        let pose = self.robot.forward(&joints);
        self.pose = pose;
        // The arm against the cell, along the period's joint-space segment.
        if let Some(event) = self.world.touch(&joints) {
            self.last_event = Some(event);
            self.events = self.events.wrapping_add(1);
        }
        let vacuum_on = outputs & (1 << (self.hand.vacuum_output & 31)) != 0;
        if let Some(event) = self.world.step(pose, vacuum_on) {
            self.last_event = Some(event);
            self.events = self.events.wrapping_add(1);
        }
        if let Some(b) = self.hand.blade_b {
            let vacuum_on = outputs & (1 << (b.vacuum_output & 31)) != 0;
            let at = Pose {
                z: pose.z + b.z_offset_mm,
                ..pose
            };
            if let Some(event) = self.world.step_blade(Blade::B, at, vacuum_on) {
                self.last_event = Some(event);
                self.events = self.events.wrapping_add(1);
            }
        }
        let previous_z = self.previous_z.replace(pose.z);
        let sensor_on = outputs & (1 << (self.hand.mapping_output & 31)) != 0;
        if let (true, Some(previous_z)) = (sensor_on, previous_z) {
            self.scan(&pose, previous_z);
        }
    }

    /// The mapping sensor at `pose`, having come from height `previous_z` \[mm\].
    fn scan(&mut self, pose: &Pose, previous_z: f64) {
        let Some(index) = self.faces.iter().position(|f| f.faced_by(pose)) else {
            return;
        };
        let face = self.faces[index];
        let (low, high) = (previous_z.min(pose.z), previous_z.max(pose.z));
        let station = index as u32 + 1;
        for slot in 1..=face.slots {
            let support = face.z1 + f64::from(slot - 1) * face.pitch;
            if !(low <= support && support <= high) {
                continue;
            }
            let Ok(content) = self.world.slot(face.name.as_str(), slot) else {
                continue;
            };
            if self.latch.station != station {
                self.latch = MappingRecord {
                    station,
                    ..MappingRecord::default()
                };
                self.latch_changed = true;
            }
            let i = usize::from(slot - 1);
            let (word, shift) = (i / 16, 2 * (i % 16));
            let codes =
                (self.latch.codes[word] & !(0b11 << shift)) | code_bits(content.code()) << shift;
            let seen = self.latch.seen | 1u64 << i;
            if codes != self.latch.codes[word] || seen != self.latch.seen {
                self.latch.codes[word] = codes;
                self.latch.seen = seen;
                self.latch_changed = true;
            }
        }
    }
}

#[cfg(test)]
mod tests;
