//! A power cut under virtual time ([`Simulation::power_cycle`]): the boards and the simulated
//! cell come back as a cell does after a power loss — the arm where it stood (absolute
//! encoders), every output off, the wafer the vacuum held dropped where the arm is — and the
//! controller starts again, not homed. These check the simulation, the physical truth; what
//! the controller's recovery makes of it is tested with the recovery.
//!
//! [`Simulation::power_cycle`]: wrc_controller::simulation::Simulation::power_cycle

use wrc_board::layout::io;
use wrc_board::wrc_cell::{SlotContent, World};
use wrc_config::Config;
use wrc_controller::simulation::POWER_OFF_NS;
use wrc_robot::Pose;

use crate::vhost::VHost;

/// One board period [ns]: the finest step at which the cell changes.
const PERIOD_NS: u64 = 10_000_000;

/// A homed controller in control that has mapped LP1 and has just been asked for
/// `GET LP1 3`.
fn getting_lp1_3() -> VHost {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert_eq!(host.ask("4 GET LP1 3"), "ACK 4");
    host
}

/// Run the simulation a board period at a time until `cut(world, hand pose)` holds (at most
/// a minute of virtual time).
fn run_until(host: &mut VHost, what: &str, cut: impl Fn(&World, Pose) -> bool) {
    for _ in 0..6_000 {
        host.sim.run_for_ns(PERIOD_NS);
        let at = host.sim.board(0).unwrap().cell().unwrap().pose();
        if cut(&host.world(), at) {
            return;
        }
    }
    panic!("{what} never came: {}", host.world().to_text());
}

/// The hand's distance from LP1's seat in x, y [mm].
fn from_lp1_seat(pose: Pose) -> f64 {
    let stations = wrc_cell::Stations::embedded_demo();
    let lp1 = &stations.get("LP1").unwrap().pose;
    (pose.x - lp1.x).hypot(pose.y - lp1.y)
}

/// What stays of the arm and the controller after the power came back, whatever the wafer
/// did: the joints where the encoders stood (WHERE within a pulse), every output off, the
/// vacuum sensor off, a new board epoch, the controller not homed, and the clock went on.
fn check_power_came_back(host: &mut VHost, encoders: &[i64], cut_ns: u64) {
    assert!(host.sim.now_ns() >= cut_ns + POWER_OFF_NS);
    assert_eq!(host.encoders(), encoders);
    let robot = Config::embedded_default().robot;
    let (joints, _, _) = host.where_();
    for ((j, p), a) in joints.iter().zip(encoders).zip(robot.axes()) {
        let stood = a.pulses_to_units(*p);
        assert!(
            (j - stood).abs() <= 1.0 / a.pulses_per_unit.abs(),
            "WHERE {joints:?}, encoders {encoders:?}"
        );
    }
    {
        let board = host.sim.board(0).unwrap();
        let dpram = board.dpram();
        assert_eq!(dpram.header().epoch, 2);
        assert_eq!(dpram.load(io::OUTPUTS), 0);
        assert_eq!(dpram.load(io::OUTPUTS_APPLIED), 0);
    }
    let status = host.status();
    assert!(status.contains(" homed=0 "), "{status}");
    assert!(!host.world().vacuum_sensor());
    let inputs = host.ask("IO");
    assert!(inputs.starts_with("ACK "), "{inputs}");
}

#[test]
fn a_power_cut_during_a_gets_lift_sets_the_wafer_back_onto_its_slot() {
    let mut host = getting_lp1_3();
    // The wafer has just come off its supports: the hand is seated, less than a stroke above
    // slot 3's support, the vacuum on.
    run_until(&mut host, "the pick", |w, _| w.hand().is_some());
    let world = host.world();
    assert_eq!(world.hand(), Some(3));
    assert_eq!(world.slot("LP1", 3).unwrap(), SlotContent::Empty);
    assert!(world.vacuum_sensor() || world.vacuum(), "the valve is open");
    assert_eq!(world.faults(), 0, "{}", world.to_text());
    let encoders = host.encoders();
    let cut_ns = host.sim.now_ns();

    let mut host = host.power_cycle();
    // The vacuum let go at the first board period: the wafer dropped back onto slot 3.
    let world = host.world();
    assert_eq!(world.hand(), None, "{}", world.to_text());
    assert_eq!(world.slot("LP1", 3).unwrap(), SlotContent::Wafer(3));
    assert_eq!((world.faults(), world.lost()), (0, &[][..]));
    assert_eq!(world.last_side_collision(), None);
    assert_eq!(world.tags().len(), 25);
    check_power_came_back(&mut host, &encoders, cut_ns);
}

#[test]
fn a_power_cut_on_the_way_out_drops_the_wafer_between_the_slot_and_the_approach_pose() {
    let mut host = getting_lp1_3();
    // Halfway out of LP1 with W3 on the hand: in free space above nothing.
    let approach_mm = 220.0;
    run_until(&mut host, "the hand halfway out", |w, at| {
        w.hand().is_some() && from_lp1_seat(at) > 0.5 * approach_mm
    });
    let world = host.world();
    assert_eq!(world.hand(), Some(3));
    assert_eq!(world.faults(), 0, "{}", world.to_text());
    let encoders = host.encoders();
    let cut_ns = host.sim.now_ns();

    let mut host = host.power_cycle();
    let world = host.world();
    assert_eq!(world.hand(), None);
    assert_eq!(world.lost(), [3], "{}", world.to_text());
    assert_eq!(world.faults(), 1, "the lost wafer, nothing else");
    assert_eq!(world.slot("LP1", 3).unwrap(), SlotContent::Empty);
    assert_eq!(world.last_side_collision(), None);
    check_power_came_back(&mut host, &encoders, cut_ns);
    // The arm is still inside LP1, on its line (where the cut left it).
    let (_, x, y) = host.where_();
    let d = from_lp1_seat(Pose {
        x,
        y,
        ..Pose::default()
    });
    assert!(
        d > 0.5 * approach_mm && d < approach_mm,
        "{d} mm from the seat"
    );
}
