//! The simulated cell on a simulated board stepped by hand: the host drives the axes through
//! the FIFO to a station, and the vacuum and mapping sensors answer through the DPRAM from
//! the world.

use std::collections::VecDeque;

use wrc_cell::{parse_slot_codes, SlotContent, Station, DEMO_NAME, DEMO_TOML};
use wrc_robot::{Posture, MAX_AXES};

use super::*;
use crate::{PowerUp, SimBoard, SimError, SimSettings};
use wrc_board::board::{Feedback, MappingScan, MotionBoard};
use wrc_board::driver::{DpramBoard, Expect, Mapping};
use wrc_board::fault::Fault;

/// Largest increment the tests command [pulse/period]: 150 000 pulse/s, below every motor
/// limit of the default robot (216 000 pulse/s and more).
const STEP: i64 = 1_500;

/// A board with the cell of `stations` (or `world`), the host on the same DPRAM, and a plan
/// of increments pushed one per period.
struct Rig {
    sim: SimBoard,
    host: DpramBoard,
    /// The DPRAM both sides share (a power-up starts on it again).
    map: Mapping,
    settings: SimSettings,
    config: Config,
    plan: VecDeque<[i64; MAX_AXES]>,
    /// Pulses at the end of the plan, robot axis order (= channel order here).
    end: [i64; MAX_AXES],
    delay_periods: u32,
}

fn rig_with(stations: Stations, world: Option<World>) -> Rig {
    let config = Config::embedded_default();
    let board = config.boards[0].clone();
    let settings = SimSettings::from_config(&config, &board);
    let map = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(map.share(), &settings, 1).unwrap();
    let mut cell = SimCell::new(&config, &board, stations).unwrap();
    if let Some(world) = world {
        cell = cell.with_world(world);
    }
    sim.attach_cell(cell).unwrap();
    let host = DpramBoard::attach(map.share(), Expect::default()).unwrap();
    let mut end = [0i64; MAX_AXES];
    for (e, s) in end.iter_mut().zip(&settings.axes) {
        *e = s.initial;
    }
    Rig {
        sim,
        host,
        map,
        config,
        plan: VecDeque::new(),
        end,
        delay_periods: settings.io.vacuum[0].delay_periods,
        settings,
    }
}

fn rig() -> Rig {
    rig_with(Stations::embedded_demo(), None)
}

impl Rig {
    fn robot(&self) -> &Robot {
        &self.config.robot
    }

    fn station(&self, name: &str) -> Station {
        self.sim
            .cell()
            .unwrap()
            .stations()
            .get(name)
            .unwrap()
            .clone()
    }

    /// Plan a joint move to `pose` (right elbow) at most [`STEP`] pulses a period per axis.
    fn plan_to(&mut self, pose: Pose) {
        let robot = self.robot().clone();
        let from = robot.pulses_to_joints(&self.end);
        let joints = robot.inverse(&pose, Posture::Right, Some(&from)).unwrap();
        let target = robot.joints_to_pulses(&joints);
        while self.end != target {
            let mut inc = [0i64; MAX_AXES];
            for ((i, e), t) in inc.iter_mut().zip(&mut self.end).zip(&target) {
                *i = (t - *e).clamp(-STEP, STEP);
                *e += *i;
            }
            self.plan.push_back(inc);
        }
    }

    /// Plan a straight TCP line to `pose` (as the controller moves inside a station), one
    /// millimetre or a tenth of a degree at most a period.
    fn plan_line(&mut self, pose: Pose) {
        let robot = self.robot().clone();
        let mut joints = robot.pulses_to_joints(&self.end);
        let from = robot.forward(&joints);
        let distance = (pose.x - from.x)
            .hypot(pose.y - from.y)
            .hypot(pose.z - from.z)
            .max(10.0 * (pose.yaw - from.yaw).abs());
        let n = distance.ceil().max(1.0) as u32;
        for i in 1..=n {
            let u = f64::from(i) / f64::from(n);
            let at = Pose {
                x: from.x + u * (pose.x - from.x),
                y: from.y + u * (pose.y - from.y),
                z: from.z + u * (pose.z - from.z),
                yaw: from.yaw + u * (pose.yaw - from.yaw),
            };
            joints = robot.inverse(&at, Posture::Right, Some(&joints)).unwrap();
            let target = robot.joints_to_pulses(&joints);
            let mut inc = [0i64; MAX_AXES];
            for ((i, e), t) in inc.iter_mut().zip(&mut self.end).zip(&target) {
                *i = t - *e;
                assert!(i.abs() <= STEP, "{i} pulses in a period");
                *e = *t;
            }
            self.plan.push_back(inc);
        }
    }

    /// [`Rig::plan_line`] and [`Rig::finish`].
    fn line(&mut self, pose: Pose) {
        self.plan_line(pose);
        self.finish();
    }

    /// One board period, with the next planned increment pushed first (a zero period at
    /// rest, as a host streams: a moving axis that finds its FIFO empty is braked).
    fn step(&mut self) {
        let inc = self.plan.pop_front().unwrap_or([0; MAX_AXES]);
        self.host.push(&inc).unwrap();
        self.sim.step();
    }

    /// Run the plan out, then let the motors settle on the command.
    fn finish(&mut self) {
        while !self.plan.is_empty() {
            self.step();
        }
        for _ in 0..10 {
            self.step();
        }
    }

    fn go(&mut self, pose: Pose) {
        self.plan_to(pose);
        self.finish();
    }

    fn world(&self) -> &World {
        self.sim.cell().unwrap().world()
    }

    fn vacuum_sensed(&self) -> bool {
        let bit = self.config.hand.vacuum_input;
        self.host.read_inputs(0) & (1 << bit) != 0
    }

    fn scan(&self) -> MappingScan {
        let mut scan = MappingScan::default();
        self.host.read_mapping(&mut scan).unwrap();
        scan
    }

    /// Sweep Z from slot 1's lowered approach pose up to the last slot's lifted one with the
    /// mapping sensor on (the controller's MAP), after clearing the latch.
    fn map_station(&mut self, name: &str) -> MappingScan {
        let s = self.station(name);
        self.go(s.approach_pose(1, false).unwrap());
        self.host.clear_mapping();
        self.step();
        let cleared = self.scan();
        assert!(cleared.cleared && cleared.seen == 0 && cleared.station == 0);
        self.host
            .write_outputs(0, 1 << self.config.hand.mapping_output);
        self.go(s.approach_pose(s.slots, true).unwrap());
        self.host.write_outputs(0, 0);
        self.step();
        self.scan()
    }
}

fn demo_with_lp1(wafers: &str) -> Stations {
    let text = DEMO_TOML.replacen("11111 11111 11111 11111 11111", wafers, 1);
    Stations::parse(&text, DEMO_NAME).unwrap()
}

#[test]
fn the_hand_pose_follows_the_encoders() {
    let mut rig = rig();
    rig.step();
    let home = rig.sim.cell().unwrap().pose();
    // Home: j1 −75°, j2 150°, j3 −75° → x = 2·200·cos 75°, y = 0, yaw 0.
    assert!(
        (home.x - 400.0 * 75f64.to_radians().cos()).abs() < 1e-6,
        "{home:?}"
    );
    assert!(home.y.abs() < 1e-6 && home.yaw.abs() < 1e-6 && home.z == 0.0);
    let lp1 = rig.station("LP1");
    let target = lp1.seated_pose(4, false).unwrap();
    rig.go(lp1.approach_pose(4, false).unwrap());
    rig.line(target);
    let pose = rig.sim.cell().unwrap().pose();
    assert!(
        (pose.x - target.x).hypot(pose.y - target.y) < 0.01 && (pose.z - target.z).abs() < 0.01,
        "{pose:?} vs {target:?}"
    );
}

#[test]
fn a_get_takes_the_wafer_and_the_vacuum_sensor_follows_after_its_delay() {
    let mut rig = rig();
    let lp1 = rig.station("LP1");
    let valve = 1 << rig.config.hand.vacuum_output;
    rig.go(lp1.approach_pose(1, false).unwrap());
    rig.line(lp1.seated_pose(1, false).unwrap());
    rig.host.write_outputs(0, valve);
    for _ in 0..3 * rig.delay_periods {
        rig.step();
    }
    assert!(
        !rig.vacuum_sensed(),
        "the valve is open, but no wafer is on the hand yet"
    );
    assert_eq!(rig.world().hand(), None);

    rig.plan_to(lp1.seated_pose(1, true).unwrap());
    let mut picked_at = None;
    for k in 0..60u32 {
        rig.step();
        if picked_at.is_none() && rig.world().hand().is_some() {
            picked_at = Some(k);
        }
        let expected = picked_at.is_some_and(|p| k - p >= rig.delay_periods);
        assert_eq!(
            rig.vacuum_sensed(),
            expected,
            "period {k}, picked at {picked_at:?}"
        );
    }
    assert!(picked_at.is_some());
    assert_eq!(rig.world().hand(), Some(1));
    assert_eq!(rig.world().slot("LP1", 1).unwrap(), SlotContent::Empty);
    assert_eq!(rig.world().slot("LP1", 2).unwrap(), SlotContent::Wafer(2));
    let event = rig.sim.take_cell_event();
    assert!(
        matches!(
            event,
            Some(WorldEvent::Picked {
                slot: 1,
                tag: 1,
                ..
            })
        ),
        "{event:?}"
    );
    assert_eq!(rig.sim.take_cell_event(), None, "an event is taken once");
    assert_eq!(rig.sim.cell().unwrap().events(), 1);

    // A vacuum sensor fault still inverts the input.
    assert!(Fault::SensorFlip { input: 0, on: true }.inject(rig.sim.dpram()));
    rig.step();
    assert!(!rig.vacuum_sensed());
    rig.sim.apply_fault(Fault::Clear);
    rig.step();
    assert!(rig.vacuum_sensed());

    // Out of the station and the valve off in free space: the wafer falls.
    rig.line(lp1.approach_pose(1, true).unwrap());
    assert_eq!(rig.world().hand(), Some(1));
    rig.host.write_outputs(0, 0);
    rig.step();
    assert_eq!(rig.world().lost(), [1]);
    assert!(matches!(
        rig.sim.take_cell_event(),
        Some(WorldEvent::Lost { tag: 1 })
    ));
    assert_eq!(rig.world().faults(), 1);
}

#[test]
fn a_z_sweep_with_the_sensor_on_latches_every_slot() {
    let mut rig = rig();
    let scan = rig.map_station("LP1");
    assert!(scan.cleared);
    assert_eq!(scan.station, 1, "LP1 is the first station of the file");
    assert_eq!(scan.seen, (1u64 << 25) - 1);
    assert_eq!(scan.codes[..25], [1u8; 25]);
    assert_eq!(scan.codes[25..], [0u8; 39]);
    assert_eq!(scan.slot_code(1), Some(SlotCode::Present));
    assert_eq!(scan.slot_code(26), None);
    assert_eq!(scan.slot_code(0), None);
    // Nothing moved: the sensor only looks.
    assert_eq!(
        rig.world().map_station("LP1").unwrap(),
        vec![SlotCode::Present; 25]
    );
    assert_eq!(rig.world().faults(), 0);

    // A sweep back down with the sensor off latches nothing.
    rig.host.clear_mapping();
    rig.step();
    let lp1 = rig.station("LP1");
    rig.go(lp1.approach_pose(1, false).unwrap());
    let scan = rig.scan();
    assert!(scan.cleared);
    assert_eq!((scan.station, scan.seen), (0, 0));

    // A clear not yet acted on is visible as such.
    rig.host.clear_mapping();
    assert!(!rig.scan().cleared);
    rig.step();
    assert!(rig.scan().cleared);
}

#[test]
fn empty_double_and_cross_slotted_slots_are_reported() {
    let wafers = "10211 X1111 11111 11111 11110";
    let mut rig = rig_with(demo_with_lp1(wafers), None);
    let scan = rig.map_station("LP1");
    let expected: Vec<u8> = parse_slot_codes(wafers)
        .unwrap()
        .into_iter()
        .map(|c| code_bits(c) as u8)
        .collect();
    assert_eq!(scan.codes[..25], expected[..]);
    assert_eq!(&scan.codes[..7], &[1, 0, 2, 1, 1, 3, 1]);
    assert_eq!(scan.slot_code(3), Some(SlotCode::Double));
    assert_eq!(scan.slot_code(6), Some(SlotCode::Cross));
    assert_eq!(scan.slot_code(25), Some(SlotCode::Absent));

    // A world read back from text, with slot 3 emptied.
    let stations = Stations::embedded_demo();
    let text = World::new(&stations)
        .to_text()
        .replacen("\"T3\"", "\"-\"", 1);
    let world = World::from_text(&text, &stations).unwrap();
    let mut rig = rig_with(stations, Some(world));
    let scan = rig.map_station("LP1");
    assert_eq!(scan.slot_code(2), Some(SlotCode::Present));
    assert_eq!(scan.slot_code(3), Some(SlotCode::Absent));
    assert_eq!(scan.seen, (1u64 << 25) - 1);
}

/// The plain cell, fed encoder positions directly.
fn cell() -> (SimCell, Config) {
    let config = Config::embedded_default();
    let cell = SimCell::new(&config, &config.boards[0], Stations::embedded_demo()).unwrap();
    (cell, config)
}

fn encoders(config: &Config, pose: Pose) -> [i64; AXES_PER_BOARD] {
    let joints = config.robot.inverse(&pose, Posture::Right, None).unwrap();
    let pulses = config.robot.joints_to_pulses(&joints);
    let mut e = [0i64; AXES_PER_BOARD];
    e.copy_from_slice(&pulses[..AXES_PER_BOARD]);
    e
}

#[test]
fn facing_another_station_clears_the_latch_and_a_wrong_yaw_sees_nothing() {
    let (mut cell, config) = cell();
    let sensor = 1 << config.hand.mapping_output;
    let stations = Stations::embedded_demo();
    let (lp1, lp2) = (stations.get("LP1").unwrap(), stations.get("LP2").unwrap());
    for slot in 1..=3 {
        cell.step(
            &encoders(&config, lp1.approach_pose(slot, false).unwrap()),
            sensor,
        );
        cell.step(
            &encoders(&config, lp1.approach_pose(slot, true).unwrap()),
            sensor,
        );
    }
    assert_eq!(cell.latch().station, 1);
    assert_eq!(cell.latch().seen, 0b111);
    assert!(cell.take_latch_change().is_some());
    assert!(cell.take_latch_change().is_none(), "a change is taken once");

    // Over to LP2 at the same height with the sensor off, then up past slot 4 with it on.
    cell.step(&encoders(&config, lp2.approach_pose(3, true).unwrap()), 0);
    assert_eq!(
        cell.latch().station,
        1,
        "the sensor is off: the latch stays"
    );
    cell.step(
        &encoders(&config, lp2.approach_pose(4, true).unwrap()),
        sensor,
    );
    let latch = *cell.latch();
    assert_eq!(
        (latch.station, latch.seen, latch.codes),
        (2, 0b1000, [0; 4])
    );

    // Turned 5° away from the station's axis: not facing it.
    cell.clear_latch();
    let mut skew = lp1.approach_pose(1, false).unwrap();
    skew.yaw += 5.0;
    cell.step(&encoders(&config, skew), sensor);
    skew.z += 30.0;
    cell.step(&encoders(&config, skew), sensor);
    assert_eq!(cell.latch().seen, 0);
}

#[test]
fn the_cell_needs_every_axis_on_its_board_and_reachable_stations() {
    let config = Config::embedded_default();
    let mut board = config.boards[0].clone();
    board.axes.truncate(3);
    let e = SimCell::new(&config, &board, Stations::embedded_demo())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("does not drive z") && e.contains("--stations"),
        "{e}"
    );

    let far = DEMO_TOML.replacen("x_mm = -308.145", "x_mm = -900.0", 1);
    let stations = Stations::parse(&far, DEMO_NAME).unwrap();
    let e = SimCell::new(&config, &config.boards[0], stations)
        .unwrap_err()
        .to_string();
    assert!(e.contains("PM1") && e.contains("cannot be reached"), "{e}");
}

#[test]
fn without_a_cell_the_mapping_words_stay_zero() {
    let config = Config::embedded_default();
    let settings = SimSettings::from_config(&config, &config.boards[0]);
    let map = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(map.share(), &settings, 1).unwrap();
    let mut host = DpramBoard::attach(map, Expect::default()).unwrap();
    host.clear_mapping();
    host.write_outputs(0, 0b11);
    for _ in 0..5 {
        sim.step();
    }
    let mut scan = MappingScan::default();
    host.read_mapping(&mut scan).unwrap();
    assert!(!scan.cleared, "no mapping sensor acknowledges the clear");
    assert_eq!((scan.station, scan.seen), (0, 0));
    assert!(sim.cell().is_none() && sim.take_cell_event().is_none());
    // The configured vacuum hand keeps its fixed wafer: sensed after the delay, as before.
    let mut f = Feedback::default();
    host.read_feedback(&mut f).unwrap();
    assert_eq!(f.boards[0].inputs & 1, 1);
}

impl Rig {
    /// The board's encoders [pulse], channel order.
    fn encoders(&self) -> Vec<i64> {
        (0..self.settings.axes.len())
            .map(|c| self.sim.axis(c).unwrap().encoder())
            .collect()
    }

    /// The board starts again on its DPRAM with `start` (the cell and its world carried
    /// over, as `wrc board-sim --world` reads them back), and the host attaches again.
    fn start_again<T>(
        &mut self,
        start: impl FnOnce(Mapping, &SimSettings) -> Result<T, SimError>,
        board: impl FnOnce(T) -> (SimBoard, Option<PowerUp>),
    ) -> Option<PowerUp> {
        let cell = self.sim.take_cell().unwrap();
        let (mut sim, how) = board(start(self.map.share(), &self.settings).unwrap());
        sim.attach_cell(cell).unwrap();
        self.sim = sim;
        self.host = DpramBoard::attach(self.map.share(), Expect::default()).unwrap();
        how
    }

    /// A restart by supervision ([`SimBoard::take_over`]).
    fn restart(&mut self) {
        self.start_again(SimBoard::take_over, |b| (b, None));
    }

    /// A power-up after a power loss ([`SimBoard::power_up`]).
    fn power_up(&mut self) -> PowerUp {
        self.start_again(SimBoard::power_up, |(b, how)| (b, Some(how)))
            .unwrap()
    }

    fn outputs(&self) -> (u32, u32) {
        let d = self.sim.dpram();
        (
            d.load(wrc_board::layout::io::OUTPUTS),
            d.load(wrc_board::layout::io::OUTPUTS_APPLIED),
        )
    }
}

/// A power-up after a power loss: the arm is where its encoders stood, every output is off,
/// and the wafer the vacuum held is released at the arm's pose in the first period: placed
/// when the hand is seated within a stroke above its slot's support, lost anywhere else. A
/// restart by supervision, before it, keeps the valve open and the wafer on the hand.
#[test]
fn a_power_up_keeps_the_encoders_clears_the_outputs_and_releases_the_held_wafer() {
    for (halfway_out, expected) in [
        (
            false,
            WorldEvent::Placed {
                station: wrc_cell::parse_station_name("LP1").unwrap(),
                slot: 1,
                tag: 1,
            },
        ),
        (true, WorldEvent::Lost { tag: 1 }),
    ] {
        let mut rig = rig();
        let lp1 = rig.station("LP1");
        let valve = 1 << rig.config.hand.vacuum_output;
        // A GET's first half: in under the wafer, vacuum on, lift it.
        rig.go(lp1.approach_pose(1, false).unwrap());
        rig.line(lp1.seated_pose(1, false).unwrap());
        rig.host.write_outputs(0, valve);
        rig.line(lp1.seated_pose(1, true).unwrap());
        if halfway_out {
            let seat = lp1.seated_pose(1, true).unwrap();
            let out = lp1.approach_pose(1, true).unwrap();
            rig.line(Pose {
                x: 0.5 * (seat.x + out.x),
                y: 0.5 * (seat.y + out.y),
                ..seat
            });
        }
        for _ in 0..rig.delay_periods {
            rig.step();
        }
        assert!(rig.vacuum_sensed());
        assert_eq!(rig.world().hand(), Some(1));
        assert_eq!(rig.world().faults(), 0, "{}", rig.world().to_text());
        let _ = rig.sim.take_cell_event();
        let encoders = rig.encoders();
        assert_ne!(encoders[0], rig.settings.axes[0].initial, "not at home");
        let pose = rig.sim.cell().unwrap().pose();

        // A restart by supervision keeps the encoders and the latched valve: the wafer
        // stays on the hand and the sensor holds.
        rig.restart();
        assert_eq!(rig.sim.dpram().header().epoch, 2);
        assert_eq!(rig.outputs().0, valve);
        rig.step();
        assert_eq!(rig.encoders(), encoders);
        assert_eq!(rig.world().hand(), Some(1));
        assert!(rig.vacuum_sensed());
        assert_eq!(rig.sim.take_cell_event(), None);

        // A power-up: the encoders again, but every output off and the wafer let go.
        let how = rig.power_up();
        assert_eq!(how, PowerUp::Resumed { epoch: 3 });
        assert_eq!(rig.sim.dpram().header().epoch, 3);
        assert_eq!(rig.encoders(), encoders);
        assert_eq!(rig.outputs(), (0, 0));
        let mut f = Feedback::default();
        rig.host.read_feedback(&mut f).unwrap();
        for (c, e) in encoders.iter().enumerate() {
            assert_eq!((f.axes[c].encoder, f.axes[c].commanded), (*e, *e));
        }
        rig.sim.step();
        assert_eq!(rig.sim.take_cell_event(), Some(expected));
        assert_eq!(rig.outputs(), (0, 0));
        assert_eq!(rig.world().hand(), None);
        assert!(!rig.vacuum_sensed());
        let at = rig.sim.cell().unwrap().pose();
        assert!(
            (at.x - pose.x).abs() < 1e-9 && (at.y - pose.y).abs() < 1e-9 && at.z == pose.z,
            "{at:?} vs {pose:?}"
        );
        if halfway_out {
            assert_eq!(rig.world().lost(), [1]);
            assert_eq!(rig.world().faults(), 1);
        } else {
            assert_eq!(rig.world().slot("LP1", 1).unwrap(), SlotContent::Wafer(1));
            assert_eq!(rig.world().faults(), 0);
        }
    }
}
