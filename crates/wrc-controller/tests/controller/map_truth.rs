//! The wafer map tells the truth after every fault, on the whole controller under virtual
//! time: a vacuum valve switched off by hand (refused with 141, then forced), a wafer that
//! slips off a blade while nothing is transferred, during a GET's line out, during a MAP and
//! during a SWAP's first half, a PUT whose wafer is gone before it starts, and transfers
//! refused at once. After every step the map saved by the controller is compared with the
//! simulated cell's ground truth (`Tracking::check`): a place may be uncertain, never
//! wrongly certain, no wafer the cell holds is forgotten, and a wafer the cell lost stays in
//! the map, uncertain, until SENSE, MAP or CONFIRM settles it.

use wrc_board::wrc_cell::{Blade, Tracking, WaferMap};
use wrc_config::Config;
use wrc_controller::simulation::SimCellFrom;
use wrc_protocol::reply_field;

use crate::vhost::{dual_blade, VHost};

/// One period of virtual time [ns].
const PERIOD_NS: u64 = 10_000_000;

/// A host in control of a homed controller of `config` with `stations` mapped, and the
/// tracking of the map's wafers against the cell's, checked once.
fn mapped(config: &Config, stations: &[&str]) -> (VHost, Tracking) {
    let mut host = VHost::start_config(config, SimCellFrom::default());
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    for (i, s) in stations.iter().enumerate() {
        let id = 3 + i as u32;
        let r = host.motion(id, &format!("MAP {s}"));
        assert!(r.starts_with(&format!("INF {id} {s} ")), "{r}");
    }
    let mut tracking = Tracking::new();
    truthful(&mut host, &mut tracking, "mapped");
    (host, tracking)
}

/// Once no transfer is pending, the wafer map the controller saved (the same as `WAFERS`
/// says) makes no claim the simulated cell contradicts and forgets no wafer it holds; the
/// `WAFERS` reply.
fn truthful(host: &mut VHost, tracking: &mut Tracking, when: &str) -> String {
    let wafers = host.settled_wafers();
    let mut map = WaferMap::load(&host.dir().join("wafers.toml")).unwrap();
    map.set_dual(wafers.contains(" hand.B="));
    assert_eq!(
        wafers,
        format!("ACK {}", map.wafers_line()),
        "{when}: WAFERS and the saved map differ"
    );
    let world = host.world();
    let wrong = tracking.check(&map, &world);
    assert!(
        wrong.is_empty(),
        "{when}: the map is wrong: {wrong:?}\n{wafers}\n{}",
        world.to_text()
    );
    wafers
}

/// `NAK <id> <code> …` for `line`; the reply.
fn refused(host: &mut VHost, id: u32, line: &str, code: u32) -> String {
    let r = host.ask(&format!("{id} {line}"));
    assert!(r.starts_with(&format!("NAK {id} {code} ")), "{line}: {r}");
    r
}

/// The lines seen that start with `prefix`.
fn seen(host: &VHost, prefix: &str) -> Vec<String> {
    host.seen
        .iter()
        .filter(|l| l.starts_with(prefix))
        .cloned()
        .collect()
}

/// The line that starts with `prefix`: one seen already, or the next to come.
fn saw(host: &mut VHost, prefix: &str) -> String {
    match host.seen.iter().find(|l| l.starts_with(prefix)) {
        Some(l) => l.clone(),
        None => host.until(prefix),
    }
}

/// Wait for the next `EVT WAFER hand=<token>` (or `hand.B=`), the map's word on a blade.
fn until_blade(host: &mut VHost, blade: Blade, token: &str) {
    let place = if blade == Blade::A { "hand" } else { "hand.B" };
    host.until(&format!("EVT WAFER {place}={token}"));
}

/// Finding 1 of the operator's report, as the demo cell showed it: GET LP1 4, then the
/// vacuum output switched off by hand. The switch is refused (141) unless forced; forced,
/// the cell drops the wafer, the controller raises 213 at once and the map shows the wafer
/// uncertain (`hand=W4?`) with `EVT RECOVERY` lines; the PUT that once recorded the wafer as
/// put into LP1 slot 4 is refused; RESET leaves the uncertainty; SENSE and MAP settle it.
#[test]
fn a_vacuum_valve_switched_off_by_hand_leaves_no_wrong_claim() {
    let (mut host, mut t) = mapped(&Config::embedded_default(), &["LP1", "LP2", "AL"]);
    assert_eq!(host.motion(10, "GET LP1 4"), "INF 10 W4");
    truthful(&mut host, &mut t, "GET LP1 4");

    // Not forced: refused, named, nothing changes.
    let r = refused(&mut host, 11, "OUT 0 0", 141);
    assert_eq!(
        r,
        "NAK 11 141 output 0 (vacuum valve) is blade A's vacuum valve and blade A holds W4: switched off, the wafer drops; send OUT 0 0 FORCE if you mean it"
    );
    host.sim.run_for_ns(500_000_000);
    assert!(
        !host.hand_empty(),
        "the valve stayed on and holds the wafer"
    );
    assert!(host.ask("STATUS").contains("state=IDLE"));
    truthful(&mut host, &mut t, "OUT 0 0 refused");

    // Forced: done, logged and told; the wafer drops; 213 at once; uncertain, not gone.
    host.seen.clear();
    assert_eq!(host.ask("12 OUT 0 0 FORCE"), "ACK 12");
    let forced = host.until("EVT RECOVERY forced OUT 0 0 by gui0: ");
    assert!(
        forced.ends_with("blade A held W4: its vacuum is off, the wafer will drop"),
        "{forced}"
    );
    let alarm = host.until("EVT ERROR 213 ");
    assert!(
        alarm.contains("input 0") && alarm.contains("blade A lost W4") && alarm.contains("SENSE"),
        "{alarm}"
    );
    until_blade(&mut host, Blade::A, "W4?");
    host.until("EVT RECOVERY uncertain hand W4");
    let next = host.until("EVT RECOVERY next ");
    assert!(next.contains("SENSE") && next.contains("CONFIRM"), "{next}");
    assert!(host.hand_empty(), "the cell dropped the wafer");
    assert_eq!(host.world().lost().len(), 1);
    let status = host.ask("STATUS");
    assert!(
        status.contains("state=ERROR") && status.contains("err=213"),
        "{status}"
    );
    let wafers = truthful(&mut host, &mut t, "OUT 0 0 FORCE");
    assert!(
        wafers.starts_with("ACK hand=W4? LP1=W1..W3,-,W5..W25 "),
        "{wafers}"
    );
    // Raised once.
    host.sim.run_for_ns(2_000_000_000);
    let _ = host.ask("STATUS");
    assert_eq!(seen(&host, "EVT ERROR 213").len(), 1, "{:?}", host.seen);

    // The PUT that once recorded W4 as put: refused in the fault, and after RESET.
    refused(&mut host, 13, "PUT LP1 4", 122);
    truthful(&mut host, &mut t, "PUT in ERROR");
    assert_eq!(host.ask("14 RESET"), "ACK 14");
    host.sim.run_for_ns(1_000_000_000);
    let wafers = truthful(&mut host, &mut t, "RESET");
    assert!(
        wafers.starts_with("ACK hand=W4? "),
        "RESET settles nothing: {wafers}"
    );
    let r = refused(&mut host, 15, "PUT LP1 4", 139);
    assert!(r.contains("W4"), "{r}");
    // A GET onto the uncertain blade is refused at once too; nothing changes.
    refused(&mut host, 16, "GET LP1 5", 139);
    truthful(&mut host, &mut t, "PUT and GET refused");
    // The valve of an uncertain wafer is still guarded.
    assert_eq!(host.ask("17 OUT 0 1"), "ACK 17");
    let r = refused(&mut host, 18, "OUT 0 0", 141);
    assert!(r.contains("blade A may hold W4?"), "{r}");

    // SENSE: no wafer on the blade, and W4 was nowhere else: it leaves the map, said so.
    host.seen.clear();
    assert_eq!(host.motion(19, "SENSE"), "INF 19 none");
    let said = saw(&mut host, "EVT RECOVERY SENSE: ");
    assert!(
        said.contains("W4 is not on the hand") && said.contains("left the wafer map"),
        "{said}"
    );
    let wafers = truthful(&mut host, &mut t, "SENSE");
    assert!(
        wafers.starts_with("ACK hand=- LP1=W1..W3,-,W5..W25 "),
        "{wafers}"
    );
    let r = host.motion(20, "MAP LP1");
    assert_eq!(r, "INF 20 LP1 1110111111111111111111111");
    truthful(&mut host, &mut t, "MAP LP1");
    assert!(host.ask("21 RECOVERY").starts_with("ACK 21 uncertain=0 "));
}

/// Finding 1's PUT itself: the wafer is already gone from the blade when `PUT LP1 4`
/// starts; its first step, the vacuum check, ends it at once (212). Judged as after a power
/// loss — the journal has the wafer on the blade, never released, the sensor sees none — the
/// wafer becomes uncertain on the blade; LP1 slot 4 stays empty (the map once recorded the
/// PUT as done: `LP1=W1..W25`, certain).
#[test]
fn a_put_whose_wafer_is_gone_before_it_starts_claims_nothing() {
    let (mut host, mut t) = mapped(&Config::embedded_default(), &["LP1", "LP2", "AL"]);
    assert_eq!(host.motion(10, "GET LP1 4"), "INF 10 W4");
    truthful(&mut host, &mut t, "GET LP1 4");
    host.seen.clear();
    host.drop_from_blade(Blade::A);
    // The board's vacuum sensor follows 50 ms later; the PUT comes before the watch outside
    // a job has seen two periods of it.
    host.sim.run_for_ns(6 * PERIOD_NS);
    let end = host.motion(11, "PUT LP1 4");
    assert!(
        end.starts_with(
            "ABS 11 212 PUT LP1 4: the vacuum sensor (input 0) sees no wafer on the hand"
        ),
        "{end}"
    );
    let wafers = truthful(&mut host, &mut t, "PUT LP1 4 with nothing on the blade");
    assert!(
        wafers.starts_with("ACK hand=W4? LP1=W1..W3,-,W5..W25 "),
        "{wafers}"
    );
    let note = saw(&mut host, "EVT RECOVERY note PUT LP1 4 (W4) ");
    assert!(
        note.contains("never released") && note.contains("senses none"),
        "{note}"
    );
    saw(&mut host, "EVT RECOVERY uncertain hand W4");
    // One alarm: the PUT's own, no 213 from the watch outside a job.
    host.sim.run_for_ns(2_000_000_000);
    let _ = host.ask("STATUS");
    assert!(seen(&host, "EVT ERROR 213").is_empty(), "{:?}", host.seen);
    assert_eq!(seen(&host, "EVT ERROR 212").len(), 1);
    assert_eq!(host.ask("12 RESET"), "ACK 12");
    assert_eq!(host.motion(13, "SENSE"), "INF 13 none");
    let wafers = truthful(&mut host, &mut t, "SENSE");
    assert!(wafers.starts_with("ACK hand=- "), "{wafers}");
}

/// A GET whose wafer the vacuum loses right after the pick, the hand still in the slot:
/// forced off there, the cell sets it back into the slot. The map had committed the GET;
/// judged with the journal (the line out had not ended), the wafer is uncertain on the
/// blade and in the slot; SENSE and MAP find it in the slot. GETs refused at once (the hand
/// uncertain, a closed interlock) change nothing.
#[test]
fn a_get_whose_vacuum_goes_off_in_the_slot_leaves_the_wafer_uncertain_in_both_places() {
    let (mut host, mut t) = mapped(&Config::embedded_default(), &["LP1", "LP2", "AL"]);
    host.seen.clear();
    assert_eq!(host.ask("10 GET LP1 6"), "ACK 10");
    // The commit: the vacuum confirmed W6 on the blade, the line out begins.
    until_blade(&mut host, Blade::A, "W6");
    assert_eq!(host.ask("11 OUT 0 0 FORCE"), "ACK 11");
    let end = host.until("ABS 10 ");
    assert!(end.starts_with("ABS 10 213 "), "{end}");
    assert!(host.hand_empty());
    assert_eq!(&host.truth("LP1")[..7], "1111111", "the cell set it back");
    let wafers = truthful(&mut host, &mut t, "GET LP1 6, vacuum off in the slot");
    assert!(
        wafers.starts_with("ACK hand=W6? LP1=W1..W5,W6?,W7..W25 "),
        "{wafers}"
    );
    assert_eq!(seen(&host, "EVT ERROR 213").len(), 1, "{:?}", host.seen);
    // Refused at once: the blade is uncertain. Nothing changes.
    assert_eq!(host.ask("12 RESET"), "ACK 12");
    refused(&mut host, 13, "GET LP1 7", 139);
    truthful(&mut host, &mut t, "GET refused, the blade uncertain");
    // Settled by the sensors: not on the blade; in the slot, as the mapping sensor sees.
    assert_eq!(host.motion(14, "HOME"), "INF 14");
    assert_eq!(host.ask("15 OUT 0 1"), "ACK 15");
    assert_eq!(host.motion(16, "SENSE"), "INF 16 none");
    let wafers = truthful(&mut host, &mut t, "SENSE");
    assert!(
        wafers.starts_with("ACK hand=- LP1=W1..W5,W6?,W7..W25 "),
        "{wafers}"
    );
    assert!(host.motion(17, "MAP LP1").starts_with("INF 17 LP1 1111111"));
    let wafers = truthful(&mut host, &mut t, "MAP LP1");
    assert!(wafers.starts_with("ACK hand=- LP1=W1..W25 "), "{wafers}");
    // A closed interlock refuses a GET before anything moves; nothing changes.
    host.inject("sensor-flip 14 on");
    host.sim.run_for_ns(200_000_000);
    refused(&mut host, 18, "GET LP1 7", 135);
    let wafers = truthful(&mut host, &mut t, "GET refused, interlock closed");
    assert!(!wafers.contains("pending="), "{wafers}");
}

/// A MAP run with a wafer on the hand watches it as a transfer does: the wafer slips off
/// during the sweep, 213 stops the robot, and the map has it uncertain on the blade, once.
#[test]
fn a_wafer_lost_from_the_hand_during_a_map_becomes_uncertain() {
    let (mut host, mut t) = mapped(&Config::embedded_default(), &["LP1", "LP2", "AL"]);
    assert_eq!(host.motion(10, "GET LP1 1"), "INF 10 W1");
    host.seen.clear();
    assert_eq!(host.ask("11 MAP LP2"), "ACK 11");
    host.wait_moving("the MAP under way", |_, _, _| true);
    host.sim.run_for_ns(20 * PERIOD_NS);
    host.drop_from_blade(Blade::A);
    let end = host.until("ABS 11 ");
    assert!(end.starts_with("ABS 11 213 "), "{end}");
    let wafers = truthful(&mut host, &mut t, "W1 lost during MAP LP2");
    assert!(
        wafers.starts_with("ACK hand=W1? LP1=-,W2..W25 "),
        "{wafers}"
    );
    let said = saw(&mut host, "EVT RECOVERY note ");
    assert!(said.contains("lost W1 during MAP"), "{said}");
    host.sim.run_for_ns(2_000_000_000);
    let _ = host.ask("STATUS");
    assert_eq!(seen(&host, "EVT ERROR 213").len(), 1, "{:?}", host.seen);
    assert_eq!(host.ask("12 RESET"), "ACK 12");
    assert_eq!(host.motion(13, "SENSE"), "INF 13 none");
    let wafers = truthful(&mut host, &mut t, "SENSE");
    assert!(wafers.starts_with("ACK hand=- "), "{wafers}");
}

/// A dual-blade robot: each blade's valve is guarded by its own wafer; a SWAP whose other
/// blade's wafer slips off during the first half (the GET) ends with 213, that wafer
/// uncertain on its blade, and the GET half judged by its journal; nothing the cell
/// contradicts at any step.
#[test]
fn a_swap_whose_other_blade_loses_its_wafer_leaves_no_wrong_claim() {
    let (mut host, mut t) = mapped(&dual_blade(), &["LP1", "PM1"]);
    assert_eq!(host.motion(10, "GET LP1 1"), "INF 10 W1");
    assert_eq!(host.motion(11, "PUT PM1 1"), "INF 11 W1");
    assert_eq!(host.motion(12, "GET LP1 2 B"), "INF 12 W2");
    truthful(&mut host, &mut t, "W2 on blade B, W1 in PM1");
    // Blade B's valve is output 2: guarded by W2; blade A's is free, A holds nothing.
    let r = refused(&mut host, 13, "OUT 2 0", 141);
    assert!(
        r.contains("output 2 (vacuum valve B) is blade B's vacuum valve and blade B holds W2"),
        "{r}"
    );
    assert_eq!(host.ask("14 OUT 0 0"), "ACK 14");
    assert_eq!(host.motion(15, "SWAP PM1 1"), "INF 15 W1 W2");
    let wafers = truthful(&mut host, &mut t, "SWAP PM1 1");
    assert!(wafers.contains("hand=W1 hand.B=- "), "{wafers}");
    // Again: blade B takes W2 back, blade A is to put W1; W1 slips off A during the GET half.
    host.seen.clear();
    assert_eq!(host.ask("16 SWAP PM1 1"), "ACK 16");
    host.wait_moving("the SWAP under way", |_, _, _| true);
    host.sim.run_for_ns(20 * PERIOD_NS);
    host.drop_from_blade(Blade::A);
    let end = host.until("ABS 16 ");
    assert!(end.starts_with("ABS 16 213 "), "{end}");
    let wafers = truthful(&mut host, &mut t, "W1 lost during the SWAP's GET half");
    assert!(wafers.contains("hand=W1? "), "{wafers}");
    host.sim.run_for_ns(2_000_000_000);
    let _ = host.ask("STATUS");
    assert_eq!(seen(&host, "EVT ERROR 213").len(), 1, "{:?}", host.seen);
    assert_eq!(host.ask("17 RESET"), "ACK 17");
    assert_eq!(host.motion(18, "HOME"), "INF 18");
    assert_eq!(host.motion(19, "SENSE A"), "INF 19 none");
    let wafers = truthful(&mut host, &mut t, "SENSE A");
    assert!(wafers.contains("hand=- "), "{wafers}");
    let b = reply_field(&wafers, "hand.B").unwrap();
    assert!(b == "W2" || b == "-", "{wafers}");
}

/// Outside a transfer, moving or not, a wafer whose sensor drops is 213 at once: the
/// robot stops (ESTOP-class) when it moves; the wafer is uncertain, and RESET keeps it so.
#[test]
fn a_wafer_that_slips_off_at_rest_or_on_a_move_is_an_alarm_at_once() {
    let (mut host, mut t) = mapped(&Config::embedded_default(), &["LP1"]);
    assert_eq!(host.motion(10, "GET LP1 2"), "INF 10 W2");
    // At rest.
    host.seen.clear();
    host.drop_from_blade(Blade::A);
    host.until("EVT ERROR 213 ");
    until_blade(&mut host, Blade::A, "W2?");
    truthful(&mut host, &mut t, "W2 slipped off at rest");
    assert_eq!(host.ask("11 RESET"), "ACK 11");
    assert_eq!(host.motion(12, "SENSE"), "INF 12 none");
    // On a move.
    assert_eq!(host.motion(13, "GET LP1 3"), "INF 13 W3");
    host.seen.clear();
    // (Under the stations: with a wafer the hand at 50 mm would end in LP1's front.)
    let ack = host.ask("14 MOVJ -60 120 -60 5");
    assert!(ack.starts_with("ACK 14"), "{ack}");
    host.wait_moving("the move under way", |_, _, _| true);
    host.drop_from_blade(Blade::A);
    let end = host.until("ABS 14 213 ");
    assert!(end.contains("lost W3"), "{end}");
    until_blade(&mut host, Blade::A, "W3?");
    truthful(&mut host, &mut t, "W3 slipped off on a move");
    assert_eq!(seen(&host, "EVT ERROR 213").len(), 1, "{:?}", host.seen);
}

/// An ESTOP anywhere in a PUT, then RESET, HOME and SENSE: the stopped transfer is settled
/// (nothing stays pending, nothing refused with 138), SENSE answers, and the map is truthful.
#[test]
fn after_an_estop_anywhere_in_a_put_reset_home_and_sense_are_answered() {
    for delay_ms in [200u64, 700, 1200, 1700, 2200, 2700, 3200] {
        let (mut host, mut t) = mapped(&Config::embedded_default(), &["LP1", "LP2"]);
        assert_eq!(host.motion(10, "GET LP1 1"), "INF 10 W1");
        assert_eq!(host.ask("11 PUT LP2 1"), "ACK 11");
        host.sim.run_for_ns(delay_ms * 1_000_000);
        assert_eq!(host.ask("ESTOP"), "ACK");
        let end = host.reply();
        assert!(
            end.starts_with("ABS 11 201") || end == "INF 11 W1",
            "at {delay_ms} ms: {end}"
        );
        truthful(&mut host, &mut t, "after the ESTOP");
        host.poll("RESET", |h| {
            let r = h.ask("12 RESET");
            if r == "ACK 12" {
                Ok(())
            } else {
                Err(r)
            }
        });
        assert_eq!(host.motion(13, "HOME"), "INF 13", "at {delay_ms} ms");
        let sense = host.motion(14, "SENSE");
        assert!(
            sense == "INF 14 wafer" || sense == "INF 14 none",
            "at {delay_ms} ms: {sense}"
        );
        truthful(&mut host, &mut t, "after SENSE");
        let r = host.motion(15, "MAP LP2");
        assert!(r.starts_with("INF 15 LP2 "), "at {delay_ms} ms: {r}");
        let map = truthful(&mut host, &mut t, "after MAP");
        assert!(
            !map.contains("W1?"),
            "at {delay_ms} ms: W1 still uncertain: {map}"
        );
    }
}
