//! Recovery after a power loss, on the whole controller under virtual time: a GET and a PUT
//! cut by a power loss after every record of their transfer journal and in the middle of
//! each of their motions; after the restart the wafer map never claims a wafer the cell
//! does not hold where it says, never forgets a wafer the cell still holds, and the
//! recovery (RESET, HOME — which first retracts a hand left inside a station — SENSE, MAP)
//! never moves the hand sideways inside a station and ends with the map equal to the cell.
//! A hand a fault left inside a station (a GET's vacuum miss) is taken straight out by
//! HOME and by the next GET or MAP before their own moves, or refused when it stands off
//! the station's line. An ESTOP anywhere in a GET or a PUT leaves the hand on the station's
//! line, and HOME takes it out.

use std::path::PathBuf;
use std::sync::atomic::Ordering;

use wrc_board::wrc_cell::journal::{read_journal, Act, Record};
use wrc_board::wrc_cell::{parse_slot_list, SlotCode, SlotState, World};
use wrc_board::Fault;
use wrc_controller::simulation::{SimCellFrom, SimClient, Simulation};
use wrc_protocol::reply_field;

use crate::vhost::{demo, map_codes, truth_codes, VHost, LINE_NS};

/// One board period [ns].
const PERIOD_NS: u64 = 10_000_000;

/// A controller in a state directory of its own, and one host on it.
struct Cell {
    sim: Simulation,
    client: SimClient,
    dir: tempfile::TempDir,
    seen: Vec<String>,
}

impl Cell {
    fn start() -> Cell {
        let dir = tempfile::tempdir().unwrap();
        let mut sim = demo(dir.path(), SimCellFrom::default());
        let client = sim.connect().unwrap();
        Cell {
            sim,
            client,
            dir,
            seen: Vec::new(),
        }
    }

    fn journal_path(&self) -> PathBuf {
        self.dir.path().join("journal.wrcj")
    }

    /// Records in the transfer journal now.
    fn records(&self) -> Vec<Record> {
        read_journal(&self.journal_path()).unwrap().records
    }

    fn line(&mut self) -> String {
        let l = self
            .sim
            .next_line(&mut self.client, LINE_NS)
            .unwrap_or_else(|e| panic!("{e}; seen: {:?}", self.seen));
        self.seen.push(l.clone());
        l
    }

    fn ask(&mut self, line: &str) -> String {
        self.sim
            .send(&mut self.client, &format!("{line}\n"))
            .unwrap();
        loop {
            let l = self.line();
            if !l.starts_with("EVT") {
                return l;
            }
        }
    }

    /// Send a motion or job with `id`: its ACK, then its final reply.
    fn motion(&mut self, id: u32, line: &str) -> String {
        let ack = self.ask(&format!("{id} {line}"));
        assert_eq!(ack, format!("ACK {id}"), "{line}: {:?}", self.seen);
        self.ended(id)
    }

    /// The final reply (`INF` or `ABS`) of the motion or job `id`, whatever comes before it.
    fn ended(&mut self, id: u32) -> String {
        let (inf, abs) = (format!("INF {id}"), format!("ABS {id}"));
        loop {
            let l = self.line();
            if l.starts_with(&inf) || l.starts_with(&abs) {
                return l;
            }
        }
    }

    fn world(&self) -> World {
        let board = self.sim.board(0).unwrap();
        board.cell().unwrap().world().clone()
    }

    fn power_cycle(self) -> Cell {
        let Cell {
            sim, client, dir, ..
        } = self;
        drop(client);
        let mut sim = sim.power_cycle().unwrap();
        let client = sim.connect().unwrap();
        Cell {
            sim,
            client,
            dir,
            seen: Vec::new(),
        }
    }
}

/// The map's slots of `station` from a `WAFERS` reply.
fn map_slots(wafers: &str, station: &str) -> Vec<SlotState> {
    let list = reply_field(wafers, station).unwrap_or_else(|| panic!("no {station} in {wafers}"));
    parse_slot_list(list).unwrap_or_else(|| panic!("{station}: {wafers}"))
}

/// The places of the map that claim something certain agree with the cell, and every wafer
/// the cell holds is in the map where it is (certain or uncertain). Returns the number of
/// uncertain places.
fn check_claims(wafers: &str, world: &World, when: &str) -> usize {
    let mut uncertain = 0;
    for station in ["LP1", "LP2", "AL"] {
        let truth = world.map_station(station).unwrap();
        for (i, (state, real)) in map_slots(wafers, station).iter().zip(&truth).enumerate() {
            let slot = i + 1;
            let ok = match state {
                SlotState::Wafer(_) => *real == SlotCode::Present,
                SlotState::Empty => *real == SlotCode::Absent,
                SlotState::Uncertain(_) => {
                    uncertain += 1;
                    true
                }
                SlotState::Unknown => true,
                SlotState::Fault(f) => *real == f.code(),
            };
            assert!(
                ok,
                "{when}: the map claims {state:?} in {station}.{slot}, the cell has {real:?}\n{wafers}\n{}",
                world.to_text()
            );
            // Never forgets a wafer the cell holds.
            if *real == SlotCode::Present {
                assert!(
                    matches!(state, SlotState::Wafer(_) | SlotState::Uncertain(_)),
                    "{when}: the cell holds a wafer in {station}.{slot}, the map says {state:?}\n{wafers}"
                );
            }
        }
    }
    let hand = reply_field(wafers, "hand").unwrap();
    match (hand, world.hand()) {
        ("-", None) => {}
        (h, _) if h.ends_with('?') => uncertain += 1,
        (h, Some(_)) if h != "-" => {}
        (h, real) => panic!("{when}: the map's hand {h}, the cell's {real:?}\n{wafers}"),
    }
    uncertain
}

/// A homed controller in control with LP1, LP2 and AL mapped.
fn mapped() -> Cell {
    let mut cell = Cell::start();
    assert!(cell.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(cell.motion(2, "HOME"), "INF 2");
    for (id, s) in [(3, "LP1"), (4, "LP2"), (5, "AL")] {
        assert!(cell
            .motion(id, &format!("MAP {s}"))
            .starts_with(&format!("INF {id}")));
    }
    cell
}

/// A mapped cell ready for the transfer under test, and that transfer (asked as id 7): a
/// GET LP1 1, or after it (done as id 6) a PUT LP2 1.
fn ready_for(put: bool) -> (Cell, &'static str) {
    let mut cell = mapped();
    if put {
        assert_eq!(cell.motion(6, "GET LP1 1"), "INF 6 W1");
        (cell, "PUT LP2 1")
    } else {
        (cell, "GET LP1 1")
    }
}

/// Where a transfer is cut: after the journal holds `records` records, and `then_ns` more.
#[derive(Debug, Clone, Copy)]
struct Cut {
    records: usize,
    then_ns: u64,
}

/// Run `cell`'s transfer (already asked for) until `cut`, period by period.
fn run_to(cell: &mut Cell, cut: Cut) {
    for _ in 0..6_000 {
        if cell.records().len() >= cut.records {
            cell.sim.run_for_ns(cut.then_ns);
            return;
        }
        cell.sim.run_for_ns(PERIOD_NS);
    }
    panic!("the journal never held {} records", cut.records);
}

/// The cuts of one transfer: after each record, and in the middle of each motion.
fn cuts(put: bool) -> Vec<Cut> {
    let (records, mut out) = motion_cuts(put, &[0.5]);
    out.splice(
        0..0,
        (1..records).map(|r| Cut {
            records: r,
            then_ns: 0,
        }),
    );
    out
}

/// Moments in each motion of one transfer, at `fractions` of it (from a reference run: the
/// virtual time from a moving step's BEGIN to the next record), and the number of records
/// the transfer's journal holds at its end.
fn motion_cuts(put: bool, fractions: &[f64]) -> (usize, Vec<Cut>) {
    let (mut cell, line) = ready_for(put);
    assert_eq!(cell.ask(&format!("7 {line}")), "ACK 7");
    let mut times: Vec<(usize, u64)> = Vec::new();
    let mut seen = 0;
    for _ in 0..6_000 {
        let n = cell.records().len();
        if n > seen {
            times.push((n, cell.sim.now_ns()));
            seen = n;
        }
        if matches!(cell.records().last(), Some(Record::Close(_))) {
            break;
        }
        cell.sim.run_for_ns(PERIOD_NS);
    }
    let records = cell.records();
    assert!(
        matches!(records.last(), Some(Record::Close(_))),
        "{records:?}"
    );
    let mut out = Vec::new();
    // From a BEGIN of a moving step to the next record.
    for (i, r) in records.iter().enumerate() {
        if let Record::Begin { act, .. } = r {
            if !act.moves() {
                continue;
            }
            let at = |k: usize| times.iter().find(|(n, _)| *n > k).map(|(_, t)| *t);
            if let (Some(begin), Some(next)) = (at(i), at(i + 1)) {
                if next > begin + 2 * PERIOD_NS {
                    out.extend(fractions.iter().map(|f| Cut {
                        records: i + 1,
                        then_ns: ((next - begin) as f64 * f) as u64,
                    }));
                }
            }
        }
    }
    (records.len(), out)
}

fn cut_and_recover(put: bool, cut: Cut) -> String {
    let (mut cell, line) = ready_for(put);
    assert_eq!(cell.ask(&format!("7 {line}")), "ACK 7");
    run_to(&mut cell, cut);
    let when = format!("{line} cut at {cut:?}");
    let mut cell = cell.power_cycle();
    // Let the start-up settle (the inputs read, the journal judged).
    cell.sim.run_for_ns(500_000_000);
    let wafers = cell.ask("WAFERS");
    let world = cell.world();
    let uncertain = check_claims(&wafers, &world, &when);
    cell.seen.clear();
    let recovery = cell.ask("10 RECOVERY");
    let said = format!("{:?} {recovery}", cell.seen);
    assert!(recovery.starts_with("ACK 10 uncertain="), "{when}: {said}");
    if uncertain > 0 {
        let status = cell.ask("STATUS");
        assert!(status.contains("err=216"), "{when}: {status}");
    }
    // The recovery an operator does: RESET, HOME, SENSE, MAP what is uncertain.
    assert!(cell.ask("11 CONTROL").starts_with("ACK 11"));
    let _ = cell.ask("12 RESET");
    let (faults, sides) = (cell.world().faults(), cell.world().side_collisions());
    let home = cell.motion(13, "HOME");
    assert_eq!(home, "INF 13", "{when}: {said} {:?}", cell.seen);
    let world = cell.world();
    assert_eq!(
        world.side_collisions(),
        sides,
        "{when}: HOME hit a station's side ({:?})",
        world.last_side_collision()
    );
    assert_eq!(world.faults(), faults, "{when}: {}", world.to_text());
    let sense = cell.motion(14, "SENSE");
    assert!(
        sense == "INF 14 wafer" || sense == "INF 14 none",
        "{when}: {sense}"
    );
    for (id, s) in [(15, "LP1"), (16, "LP2")] {
        let r = cell.motion(id, &format!("MAP {s}"));
        assert!(r.starts_with(&format!("INF {id}")), "{when}: {r}");
    }
    let wafers = cell.ask("WAFERS");
    let world = cell.world();
    assert_eq!(check_claims(&wafers, &world, &when), 0, "{when}: {wafers}");
    for s in ["LP1", "LP2"] {
        let codes: String = map_slots(&wafers, s)
            .iter()
            .map(|st| st.code().map_or('?', SlotCode::as_char))
            .collect();
        assert_eq!(codes, truth_codes(&cell.sim, s), "{when}: {s}");
    }
    let recovery = cell.ask("17 RECOVERY");
    assert!(
        recovery.starts_with("ACK 17 uncertain=0 inside=-"),
        "{when}: {recovery}"
    );
    said
}

/// Cut `put`'s transfer by a power loss after every record of its journal and in the middle
/// of every motion, and recover each time.
fn cut_anywhere_and_recover(put: bool) {
    let cuts = cuts(put);
    assert!(cuts.len() > 12, "{cuts:?}");
    let mut inside = 0;
    for cut in cuts {
        let said = cut_and_recover(put, cut);
        inside += usize::from(said.contains(" inside=LP"));
    }
    // The hand was left inside the station (and HOME took it out first) in several.
    assert!(inside >= 4, "{inside} cuts left the hand inside");
}

#[test]
fn a_get_cut_by_a_power_loss_anywhere_is_recovered_without_a_wrong_claim() {
    cut_anywhere_and_recover(false);
}

#[test]
fn a_put_cut_by_a_power_loss_anywhere_is_recovered_without_a_wrong_claim() {
    cut_anywhere_and_recover(true);
}

/// A host in control, homed, with LP1 mapped; the simulated cell's side collisions so far.
fn mapped_lp1() -> (VHost, u32) {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    let sides = host.world().side_collisions();
    (host, sides)
}

/// Take the wafer of LP1's slot `slot` out of the simulated cell (someone took it away by
/// hand after the mapping), and GET it: the blade finds nothing after the lift (212) and
/// the fault leaves the hand inside LP1; RESET.
fn miss_inside_lp1(host: &mut VHost, id: u32, slot: u16) {
    let mut board = host.sim.board(0).unwrap();
    let cell = board.take_cell().unwrap();
    let text = cell.world().to_text();
    let edited = text.replacen(&format!("\"T{slot}\""), "\"-\"", 1);
    assert_ne!(edited, text);
    let world = World::from_text(&edited, cell.stations()).unwrap();
    board.attach_cell(cell.with_world(world)).unwrap();
    drop(board);
    let r = host.motion(id, &format!("GET LP1 {slot}"));
    assert!(r.starts_with(&format!("ABS {id} 212")), "{r}");
    host.settled_wafers();
    let recovery = host.ask(&format!("{} RECOVERY", id + 1));
    assert!(recovery.contains(" inside=LP1 "), "{recovery}");
    assert_eq!(
        host.ask(&format!("{} RESET", id + 2)),
        format!("ACK {}", id + 2)
    );
}

#[test]
fn a_hand_a_fault_left_inside_a_station_is_taken_straight_out_before_anything_else() {
    let (mut host, sides) = mapped_lp1();
    let straight = |host: &VHost, what: &str| {
        let world = host.world();
        assert_eq!(
            world.side_collisions(),
            sides,
            "{what} hit a station's side: {:?}",
            world.last_side_collision()
        );
    };
    // HOME: out along LP1's line first.
    miss_inside_lp1(&mut host, 10, 2);
    assert_eq!(host.motion(13, "HOME"), "INF 13");
    straight(&host, "HOME");
    assert!(host.ask("14 RECOVERY").contains(" inside=- "));
    // The next GET: out first (journaled as LEAVE), then its own approach.
    miss_inside_lp1(&mut host, 20, 3);
    assert_eq!(host.motion(23, "GET LP1 4"), "INF 23 W4");
    straight(&host, "GET");
    let journal = read_journal(&host.dir().join("journal.wrcj")).unwrap();
    let first_move = journal.records.iter().find_map(|r| match r {
        Record::Begin { act, .. } if act.moves() => Some(*act),
        _ => None,
    });
    assert_eq!(first_move, Some(Act::Leave), "{:?}", journal.records);
    assert_eq!(host.motion(24, "PUT LP1 4"), "INF 24 W4");
    // A MAP: out first too, and the map then equals the cell.
    miss_inside_lp1(&mut host, 30, 5);
    assert!(host.motion(33, "MAP LP1").starts_with("INF 33"));
    straight(&host, "MAP");
    assert_eq!(map_codes(&host.ask("WAFERS"), "LP1"), host.truth("LP1"));
    // A jog that would turn it off the line inside LP1 stops short, at the station's
    // boundary, and says so: no side hit.
    miss_inside_lp1(&mut host, 40, 6);
    let sides = host.world().side_collisions();
    let jog = host.ask("43 JOG 1 2000");
    assert!(jog.starts_with("ACK 43 limited=LP1 jog="), "{jog}");
    assert_eq!(host.reply(), "INF 43");
    assert_eq!(host.world().side_collisions(), sides);
    assert_eq!(host.motion(44, "HOME"), "INF 44");
    straight(&host, "the limited jog and HOME");
}

/// A hand a fault left inside a station more than 5 degrees off its line cannot be taken
/// straight out: GET and HOME are refused (140) and nothing moves. (Off the line inside a
/// station the arm touches it: to put it there by a jog, LP1's box is moved out of the
/// hand's way in this cell; the rule of 140 is the same.)
#[test]
fn a_hand_far_off_a_stations_line_is_refused_not_scraped_out() {
    let dir = tempfile::tempdir().unwrap();
    let stations = dir.path().join("stations.toml");
    let text = wrc_board::wrc_cell::DEMO_TOML.replacen(
        "[station.sim]\nwafers = \"11111 11111 11111 11111 11111\"\n",
        "[station.sim]\nwafers = \"11111 11111 11111 11111 11111\"\n\n[station.volume]\nmouth_mm = -400.0\ndepth_mm = 10.0\n",
        1,
    );
    assert_ne!(text, wrc_board::wrc_cell::DEMO_TOML);
    std::fs::write(&stations, text).unwrap();
    let mut host = VHost::start_with(SimCellFrom {
        stations: Some(&stations),
        ..SimCellFrom::default()
    });
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    miss_inside_lp1(&mut host, 40, 6);
    assert_eq!(host.motion(43, "JOG 1 2000"), "INF 43");
    let before = host.encoders();
    let get = host.ask("44 GET LP1 7");
    assert!(
        get.starts_with("NAK 44 140 ") && get.contains("off its line"),
        "{get}"
    );
    let home = host.ask("45 HOME");
    assert!(
        home.starts_with("NAK 45 140 ") && home.contains("off its line"),
        "{home}"
    );
    host.sim.run_for_ns(200_000_000);
    assert_eq!(host.encoders(), before);
}

/// When an ESTOP comes in a transfer.
#[derive(Debug, Clone, Copy)]
enum StopAt {
    /// At a moment of one of its motions.
    Motion(Cut),
    /// This many periods after the Pulse Generator first sent the transfer's pulses from a
    /// state committed to enter the station (a blended approach's first part past its
    /// commit point, or the line in).
    Committed(u64),
}

/// ESTOP a GET LP1 1 (or a PUT LP2 1 after it) at `at`: the hand ends on the station's
/// line or outside it (the simulated cell sees no side collision), the wafer map settled
/// from the sensors agrees with the cell, and after RESET, HOME takes the hand out without
/// a side collision.
fn estop_keeps_the_line(put: bool, at: StopAt, by: EstopBy) {
    let (mut cell, line) = ready_for(put);
    let committed = cell.sim.shared().entry_committed.load(Ordering::Acquire);
    assert_eq!(cell.ask(&format!("7 {line}")), "ACK 7");
    match at {
        StopAt::Motion(cut) => run_to(&mut cell, cut),
        StopAt::Committed(periods) => {
            let shared = cell.sim.shared().clone();
            let mut left = 3_000;
            while shared.entry_committed.load(Ordering::Acquire) == committed {
                assert!(left > 0, "{line}: never committed to enter");
                left -= 1;
                cell.sim.run_for_ns(PERIOD_NS);
            }
            cell.sim.run_for_ns(periods * PERIOD_NS);
        }
    }
    let when = format!("{line}, {by:?} ESTOP at {at:?}");
    let sides = cell.world().side_collisions();
    match by {
        EstopBy::Command => {
            cell.sim.send(&mut cell.client, "8 ESTOP\n").unwrap();
        }
        EstopBy::Input => {
            let mut board = cell.sim.board(0).unwrap();
            board.apply_fault(Fault::Estop { on: true });
        }
    }
    cell.ended(7);
    // The map settles the ended transfer from the vacuum sensor once the arm stands still
    // and the sensor has answered (a HOME sent sooner, after a PUT's release, carries a
    // wafer the map still has on the hand and ends in 213, wafer lost): wait for that.
    // (`WAFERS` names a pending transfer only while there is one.)
    let settled = |w: &str| matches!(reply_field(w, "pending"), None | Some("-"));
    let mut wafers = cell.ask("WAFERS");
    for _ in 0..300 {
        if cell.sim.at_rest() && settled(&wafers) {
            break;
        }
        cell.sim.run_for_ns(PERIOD_NS);
        wafers = cell.ask("WAFERS");
    }
    assert!(settled(&wafers), "{when}: never settled: {wafers}");
    let world = cell.world();
    assert_eq!(
        world.side_collisions(),
        sides,
        "{when}: the stop hit {:?}'s side; {:?}",
        world.last_side_collision(),
        cell.seen
    );
    // The map settled from the sensors makes no claim the cell contradicts, and forgets no
    // wafer.
    check_claims(&wafers, &world, &when);
    if by == EstopBy::Input {
        cell.sim
            .board(0)
            .unwrap()
            .apply_fault(Fault::Estop { on: false });
        // Until the I/O Monitor has read the input closed (at its next period).
        let shared = cell.sim.shared().clone();
        let bit = wrc_config::Config::embedded_default()
            .estop_input()
            .expect("the demo board has an E-stop input");
        let open = || shared.inputs[0].load(Ordering::Acquire) & (1 << bit) != 0;
        for _ in 0..100 {
            if !open() {
                break;
            }
            cell.sim.run_for_ns(PERIOD_NS);
        }
        assert!(
            !open(),
            "{when}: the controller never read the E-stop input closed"
        );
    }
    let reset = cell.ask("9 RESET");
    assert!(reset.starts_with("ACK 9"), "{when}: {reset}");
    assert_eq!(cell.motion(10, "HOME"), "INF 10", "{when}: {:?}", cell.seen);
    let world = cell.world();
    assert_eq!(
        world.side_collisions(),
        sides,
        "{when}: HOME hit {:?}'s side",
        world.last_side_collision()
    );
    let recovery = cell.ask("11 RECOVERY");
    assert!(
        recovery.starts_with("ACK 11 uncertain=0 inside=-"),
        "{when}: {recovery}"
    );
}

/// Found by stopping every 50 ms: a stop the Command Interpreter asked for again when the
/// ESTOP ended the job made the board brake each axis on its own (up to 11 mm and 6 degrees
/// off the line inside LP1), and a stop past a blended approach's commit point braked each
/// axis on its own (up to 13 mm and 11 degrees off LP2's line).
#[test]
fn an_estop_anywhere_in_a_get_or_a_put_leaves_the_hand_on_the_stations_line() {
    for put in [false, true] {
        let (_, moments) = motion_cuts(put, &[0.25, 0.5, 0.75]);
        // A blended approach's first part goes on for about 25 periods after it commits;
        // stops 14 to 24 periods in ended inside the station, off its line.
        let committed = (0..=30).step_by(5).map(StopAt::Committed);
        for at in moments.into_iter().map(StopAt::Motion).chain(committed) {
            estop_keeps_the_line(put, at, EstopBy::Command);
        }
    }
}

/// The E-stop button (the board's input) in a GET or a PUT: the same as ESTOP. Found by the
/// controller's tests on the wrc crate: the board braked each axis itself the period the
/// input opened, and a GET LP1 stopped on its line in leaves it (a side collision). The
/// board now gives the host two periods to flush its brake along the path (docs/dpram.md,
/// "Stops" 6).
#[test]
fn the_estop_button_anywhere_in_a_get_or_a_put_leaves_the_hand_on_the_stations_line() {
    for put in [false, true] {
        let (_, moments) = motion_cuts(put, &[0.3, 0.7]);
        let committed = (0..=30).step_by(10).map(StopAt::Committed);
        for at in moments.into_iter().map(StopAt::Motion).chain(committed) {
            estop_keeps_the_line(put, at, EstopBy::Input);
        }
    }
}

/// How the emergency stop comes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum EstopBy {
    /// `ESTOP` from the host.
    Command,
    /// The E-stop button: the board's E-stop input opens (and closes again before RESET).
    Input,
}
