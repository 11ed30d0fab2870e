//! The journal's lines, reading a journal a power cut damaged, and the judgement of a GET
//! and a PUT interrupted at every step, with the valve kept on (only the controller
//! stopped) or switched off (a power loss).

use super::*;

fn transfer(kind: TransferKind) -> Transfer {
    Transfer {
        kind,
        station: parse_station_name("LP2").unwrap(),
        slot: 3,
        wafer: WaferId(7),
        blade: Blade::A,
    }
}

fn pose(x: f64) -> Pose {
    Pose {
        x,
        y: -12.5,
        z: 30.25,
        yaw: 90.0,
    }
}

/// A blended GET's acts, as the controller plans them.
const GET: [Act; 7] = [
    Act::Enter,
    Act::VacuumOn,
    Act::Lift,
    Act::CheckWafer,
    Act::Commit,
    Act::Out,
    Act::Speed,
];

/// A blended PUT's acts.
const PUT: [Act; 8] = [
    Act::CheckWafer,
    Act::Enter,
    Act::VacuumOff,
    Act::Lower,
    Act::CheckNoWafer,
    Act::Commit,
    Act::Out,
    Act::Speed,
];

/// The records of `plan` for `t` up to and including the `n`-th record after OPEN (each
/// step has a BEGIN and a DONE).
fn records(t: Transfer, plan: &[Act], n: usize) -> Vec<Record> {
    let mut all = vec![Record::Open {
        transfer: Some(t),
        station: t.station,
        plan: plan.to_vec(),
    }];
    for (i, act) in plan.iter().enumerate() {
        all.push(Record::Begin {
            step: i as u8,
            act: *act,
            to: act.moves().then(|| pose(i as f64)),
            at: pose(i as f64 - 0.5),
        });
        all.push(Record::Done {
            step: i as u8,
            act: *act,
            at: pose(i as f64),
        });
    }
    all.truncate(n + 1);
    all
}

#[test]
fn every_record_reads_back_from_its_line_and_a_damaged_line_is_refused() {
    let t = transfer(TransferKind::Put);
    let mut all = records(t, &PUT, 100);
    all.push(Record::Transfer(transfer(TransferKind::Get)));
    all.push(Record::Open {
        transfer: None,
        station: t.station,
        plan: vec![Act::Scan, Act::Scan],
    });
    for how in [
        Closed::Committed,
        Closed::Aborted,
        Closed::Settled,
        Closed::Uncertain,
        Closed::Ended,
    ] {
        all.push(Record::Close(how));
    }
    for (seq, r) in (1..).zip(&all) {
        let line = journal_line(seq, r);
        assert!(line.ends_with('\n'), "{line}");
        let body = line.trim_end();
        assert_eq!(parse_journal_line(body), Some((seq, r.clone())), "{line}");
        // Any changed byte fails the CRC (or the syntax).
        for i in 0..body.len() {
            let mut bytes = body.as_bytes().to_vec();
            bytes[i] ^= 0x01;
            let damaged = String::from_utf8_lossy(&bytes).into_owned();
            assert_eq!(parse_journal_line(&damaged), None, "{damaged}");
        }
    }
    assert_eq!(Record::parse("BEGIN 1 LIFT at=1,2,3"), None);
    assert_eq!(Record::parse("DONE 1 LIFT to=1,2,3,4 at=1,2,3,4"), None);
    assert_eq!(Record::parse("CLOSE committed extra"), None);
    assert_eq!(Record::parse("OPEN get LP1 0 A W1 plan=BOGUS"), None);
}

#[test]
fn reading_stops_at_the_line_a_power_cut_left_half_written() {
    let t = transfer(TransferKind::Get);
    let all = records(t, &GET, 6);
    let text: String = (1..)
        .zip(&all)
        .map(|(seq, r)| journal_line(seq, r))
        .collect();
    let whole = read_journal_text(&text);
    assert_eq!(whole.records, all);
    assert_eq!(whole.torn_at, None);
    // Cut anywhere inside the last line: the records before it are kept.
    let last_start = text[..text.len() - 1].rfind('\n').unwrap() + 1;
    for cut in last_start..text.len() {
        let read = read_journal_text(&text[..cut]);
        assert_eq!(read.records, all[..all.len() - 1], "cut at {cut}");
        assert_eq!(read.torn_at.is_some(), cut > last_start, "cut at {cut}");
    }
    // Garbage in the middle: reading stops there.
    let garbled = text.replacen("BEGIN 1", "BEGIN 9", 1);
    assert_eq!(read_journal_text(&garbled).records, all[..3]);
    assert_eq!(read_journal_text(&garbled).torn_at, Some(4));
}

#[test]
fn the_file_starts_anew_at_each_open_and_every_append_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("journal.wrcj");
    assert_eq!(read_journal(&path).unwrap(), JournalText::default());
    let mut file = JournalFile::open(&path).unwrap();
    let first = records(transfer(TransferKind::Get), &GET, 100);
    file.restart(&first[0]).unwrap();
    for r in &first[1..] {
        file.append(r).unwrap();
    }
    file.append(&Record::Close(Closed::Committed)).unwrap();
    let second = records(transfer(TransferKind::Put), &PUT, 3);
    file.restart(&second[0]).unwrap();
    for r in &second[1..] {
        file.append(r).unwrap();
    }
    drop(file);
    let read = read_journal(&path).unwrap();
    assert_eq!(read.records, second);
    // A new process appends after what is there.
    let mut again = JournalFile::open(&path).unwrap();
    again.append(&Record::Close(Closed::Aborted)).unwrap();
    assert_eq!(read_journal(&path).unwrap().records.len(), second.len() + 1);
}

const VALVE_OFF: Evidence = Evidence {
    valve_on: false,
    sensed: false,
};
const HELD: Evidence = Evidence {
    valve_on: true,
    sensed: true,
};
const NOT_HELD: Evidence = Evidence {
    valve_on: true,
    sensed: false,
};

fn verdict(t: Transfer, plan: &[Act], n: usize, e: Evidence) -> (Maybe, Maybe, bool) {
    let j = judge(&records(t, plan, n), e);
    assert!(j.open());
    assert_eq!(j.transfer, Some(t));
    assert!(j.text.contains(&t.to_string()), "{}", j.text);
    (j.on_blade, j.in_slot, j.inside)
}

#[test]
fn a_get_interrupted_at_each_record_after_a_power_loss() {
    use Maybe::*;
    let t = transfer(TransferKind::Get);
    // (records after OPEN, on the blade, in the slot, inside)
    let want = [
        (0, No, Yes, false),          // OPEN only
        (1, No, Yes, true),           // BEGIN ENTER
        (2, No, Yes, true),           // DONE ENTER
        (3, No, Yes, true),           // BEGIN VACON: no lift yet
        (4, No, Yes, true),           // DONE VACON
        (5, Perhaps, Perhaps, true),  // BEGIN LIFT
        (6, Perhaps, Perhaps, true),  // DONE LIFT
        (7, Perhaps, Perhaps, true),  // BEGIN CHECK1
        (8, Perhaps, Perhaps, true),  // DONE CHECK1: confirmed, but the vacuum went off
        (9, Perhaps, Perhaps, true),  // BEGIN COMMIT
        (10, Perhaps, Perhaps, true), // DONE COMMIT
        (11, Perhaps, Perhaps, true), // BEGIN OUT
        (12, Perhaps, No, false),     // DONE OUT: out of the station with it
        (14, Perhaps, No, false),     // DONE SPEED
    ];
    for (n, blade, slot, inside) in want {
        assert_eq!(
            verdict(t, &GET, n, VALVE_OFF),
            (blade, slot, inside),
            "{n} records"
        );
    }
}

/// A GET that first leaves the station the hand stood in (a fault left it there): the
/// straight line out before the approach.
const GET_AFTER_LEAVE: [Act; 10] = [
    Act::Speed,
    Act::Leave,
    Act::Speed,
    Act::Enter,
    Act::VacuumOn,
    Act::Lift,
    Act::CheckWafer,
    Act::Commit,
    Act::Out,
    Act::Speed,
];

#[test]
fn a_get_that_first_left_a_station_is_judged_by_its_own_line_out_only() {
    use Maybe::*;
    let t = transfer(TransferKind::Get);
    let want = [
        (2, No, Yes, false),          // DONE SPEED
        (3, No, Yes, true),           // BEGIN LEAVE: still in the station it stood in
        (4, No, Yes, false),          // DONE LEAVE: out
        (7, No, Yes, true),           // BEGIN ENTER
        (12, Perhaps, Perhaps, true), // DONE LIFT
        (14, Perhaps, Perhaps, true), // DONE CHECK1: the earlier line out is not this one
        (17, Perhaps, Perhaps, true), // BEGIN OUT
        (18, Perhaps, No, false),     // DONE OUT
    ];
    for (n, blade, slot, inside) in want {
        assert_eq!(
            verdict(t, &GET_AFTER_LEAVE, n, VALVE_OFF),
            (blade, slot, inside),
            "{n} records"
        );
    }
    assert_eq!(Act::parse(Act::Leave.word()), Some(Act::Leave));
    assert!(Act::Leave.moves());
}

#[test]
fn a_get_interrupted_with_the_valve_kept_on_is_settled_by_the_sensor() {
    use Maybe::*;
    let t = transfer(TransferKind::Get);
    for n in 3..=14 {
        assert_eq!(verdict(t, &GET, n, HELD).0, Yes, "{n}");
        assert_eq!(verdict(t, &GET, n, HELD).1, No, "{n}");
    }
    // Not sensed before the lift ended: the wafer stayed in the slot.
    for n in 3..=5 {
        assert_eq!(verdict(t, &GET, n, NOT_HELD).0, No, "{n}");
        assert_eq!(verdict(t, &GET, n, NOT_HELD).1, Yes, "{n}");
    }
    // The lift through the slot ended with the vacuum on and nothing sensed: the slot may
    // have been empty; it is uncertain, not claimed.
    for n in 6..=7 {
        assert_eq!(verdict(t, &GET, n, NOT_HELD), (No, Perhaps, true), "{n}");
    }
    // Confirmed, then not sensed: the journal and the sensor disagree. Uncertain on the
    // blade (where it was last) and, until the hand is out, back in the slot; never out of
    // the map on the sensor's word.
    assert_eq!(verdict(t, &GET, 8, NOT_HELD), (Perhaps, Perhaps, true));
    assert_eq!(verdict(t, &GET, 12, NOT_HELD), (Perhaps, No, false));
}

#[test]
fn a_put_interrupted_at_each_record_after_a_power_loss() {
    use Maybe::*;
    let t = transfer(TransferKind::Put);
    let want = [
        (0, Perhaps, No, false), // OPEN only: the vacuum went off with the wafer held
        (2, Perhaps, No, false), // DONE CHECK1
        (3, Perhaps, Perhaps, true), // BEGIN ENTER
        (4, Perhaps, Perhaps, true), // DONE ENTER
        (5, No, Yes, true),      // BEGIN VACOFF: at the seat, and the valve is off
        (6, No, Yes, true),      // DONE VACOFF: released at the seat
        (7, No, Yes, true),      // BEGIN LOWER
        (13, No, Yes, true),     // BEGIN OUT
        (14, No, Yes, false),    // DONE OUT
        (16, No, Yes, false),    // DONE SPEED
    ];
    for (n, blade, slot, inside) in want {
        assert_eq!(
            verdict(t, &PUT, n, VALVE_OFF),
            (blade, slot, inside),
            "{n} records"
        );
    }
    // The valve kept on: the sensor confirms a wafer still held; one it no longer senses,
    // never released, stays uncertain on the blade (and in the slot once the hand entered).
    assert_eq!(verdict(t, &PUT, 4, HELD), (Yes, No, true));
    assert_eq!(verdict(t, &PUT, 4, NOT_HELD), (Perhaps, Perhaps, true));
    assert_eq!(verdict(t, &PUT, 2, NOT_HELD), (Perhaps, No, false));
    assert_eq!(verdict(t, &PUT, 0, NOT_HELD), (Perhaps, No, false));
    // The release had begun but the valve is still on (not applied yet): the sensor tells.
    assert_eq!(verdict(t, &PUT, 5, HELD), (Yes, No, true));
}

/// No judgement takes a wafer out of the map: whatever the records and the sensors, the
/// wafer may still be on the blade or in the slot.
#[test]
fn no_judgement_takes_a_wafer_out_of_the_map() {
    for (kind, plan) in [(TransferKind::Get, &GET[..]), (TransferKind::Put, &PUT[..])] {
        let t = transfer(kind);
        for n in 0..=2 * plan.len() {
            for e in [VALVE_OFF, HELD, NOT_HELD] {
                let (blade, slot, _) = verdict(t, plan, n, e);
                assert!(
                    blade != Maybe::No || slot != Maybe::No,
                    "{kind} after {n} records with {e:?}"
                );
            }
        }
    }
}

#[test]
fn a_swap_is_judged_by_its_current_half_and_a_closed_or_empty_journal_by_nothing() {
    use Maybe::*;
    let get = Transfer {
        blade: Blade::B,
        ..transfer(TransferKind::Get)
    };
    let put = Transfer {
        wafer: WaferId(9),
        ..transfer(TransferKind::Put)
    };
    let mut all = records(get, &GET[..5], 10);
    all.push(Record::Transfer(put));
    all.push(Record::Begin {
        step: 6,
        act: Act::VacuumOff,
        to: None,
        at: pose(6.0),
    });
    let j = judge(&all, VALVE_OFF);
    assert_eq!(j.transfer, Some(put));
    // Released at the seat: the PUT half's line in was its GET half's.
    assert_eq!((j.on_blade, j.in_slot, j.inside), (No, Yes, true));
    assert_eq!(
        (
            judge(&all, NOT_HELD).on_blade,
            judge(&all, NOT_HELD).in_slot
        ),
        (Perhaps, Perhaps)
    );
    all.push(Record::Done {
        step: 6,
        act: Act::VacuumOff,
        at: pose(6.0),
    });
    assert_eq!(judge(&all, VALVE_OFF).in_slot, Yes);

    let mut closed = records(transfer(TransferKind::Get), &GET, 100);
    closed.push(Record::Close(Closed::Committed));
    assert!(!judge(&closed, VALVE_OFF).open());
    assert!(!judge(&[], VALVE_OFF).open());
    // A mapping scan: no wafer, but the hand may be inside.
    let station = parse_station_name("LP1").unwrap();
    let scan = vec![
        Record::Open {
            transfer: None,
            station,
            plan: vec![Act::Enter, Act::Scan, Act::Out],
        },
        Record::Begin {
            step: 0,
            act: Act::Enter,
            to: Some(pose(0.0)),
            at: pose(-1.0),
        },
    ];
    let j = judge(&scan, VALVE_OFF);
    assert!(j.open() && j.inside && j.transfer.is_none());
    assert!(
        j.text
            .starts_with("a MAP of LP1 was interrupted during step 1"),
        "{}",
        j.text
    );
}
