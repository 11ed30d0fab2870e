use super::*;
use crate::station::parse_station_name;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

fn demo() -> Stations {
    Stations::embedded_demo()
}

fn name(s: &str) -> StationName {
    parse_station_name(s).unwrap()
}

fn at(station: &str, slot: u16) -> Location {
    Location::Slot {
        station: name(station),
        slot,
    }
}

/// The demo map with LP1 full (W1..W25) and every other station mapped empty.
fn mapped() -> WaferMap {
    let mut map = WaferMap::new(&demo());
    map.apply_mapping("LP1", &[SlotCode::Present; 25]).unwrap();
    map.apply_mapping("LP2", &[SlotCode::Absent; 25]).unwrap();
    for s in ["AL", "PM1", "PM2"] {
        map.apply_mapping(s, &[SlotCode::Absent]).unwrap();
    }
    map
}

fn ids(map: &WaferMap) -> Vec<WaferId> {
    let mut v: Vec<WaferId> = map.iter().map(|(_, w)| w).collect();
    v.sort();
    v
}

#[test]
fn wafer_ids_read_and_print() {
    assert_eq!(WaferId::parse("W12"), Some(WaferId(12)));
    assert_eq!(WaferId::parse("w7"), Some(WaferId(7)));
    for bad in ["", "W", "12", "W-1", "W+1", "W1x", "W99999999999", "X1"] {
        assert_eq!(WaferId::parse(bad), None, "{bad}");
    }
    assert_eq!(WaferId(3).to_string(), "W3");
    assert_eq!(at("LP1", 3).to_string(), "LP1.3");
    assert_eq!(Location::HAND.to_string(), "hand");
}

#[test]
fn a_new_map_knows_nothing_and_refuses_transfers() {
    let map = WaferMap::new(&demo());
    assert!(map.is_empty());
    assert_eq!(map.slot("LP1", 1).unwrap(), SlotState::Unknown);
    let e = map.prepare(TransferKind::Get, "LP1", 1).unwrap_err();
    assert!(matches!(e, WaferMapError::SlotUnknown { slot: 1, .. }));
    assert!(e.to_string().contains("MAP LP1"), "{e}");
    assert!(map.prepare(TransferKind::Put, "PM1", 1).is_err());
    assert_eq!(
        map.wafers_line(),
        "hand=- LP1=?x25 LP2=?x25 AL=? PM1=? PM2=? BF1=?x5"
    );
}

#[test]
fn mapping_gives_ids_keeps_known_ones_and_reports_changes() {
    let mut map = mapped();
    assert_eq!(map.len(), 25);
    assert_eq!(map.wafer_at(&at("LP1", 25)), Some(WaferId(25)));
    assert_eq!(map.location_of(WaferId(4)), Some(at("LP1", 4)));

    // Re-map with slot 2 empty, slot 3 double, slot 4 cross: W1, W5.. kept; W2, W3, W4 gone.
    let mut codes = vec![SlotCode::Present; 25];
    codes[1] = SlotCode::Absent;
    codes[2] = SlotCode::Double;
    codes[3] = SlotCode::Cross;
    let changes = map.apply_mapping("lp1", &codes).unwrap();
    assert!(changes.created.is_empty());
    assert_eq!(changes.kept.len(), 22);
    assert_eq!(
        changes.removed,
        [(2, WaferId(2)), (3, WaferId(3)), (4, WaferId(4))]
    );
    assert_eq!(
        changes.faults,
        [(3, SlotFault::Double), (4, SlotFault::Cross)]
    );
    assert_eq!(
        map.slot("LP1", 3).unwrap(),
        SlotState::Fault(SlotFault::Double)
    );

    // Present again where it was empty: a new id, never a reused one.
    let changes = map.apply_mapping("LP1", &[SlotCode::Present; 25]).unwrap();
    assert_eq!(
        changes.created,
        [(2, WaferId(26)), (3, WaferId(27)), (4, WaferId(28))]
    );
    map.verify().unwrap();

    let e = map
        .apply_mapping("LP1", &[SlotCode::Present; 24])
        .unwrap_err();
    assert!(
        e.to_string()
            .contains("25 slots but the mapping reported 24"),
        "{e}"
    );
    assert!(matches!(
        map.apply_mapping("LP9", &[]),
        Err(WaferMapError::NoSuchStation { .. })
    ));
}

#[test]
fn get_then_put_moves_the_wafer_in_two_phases() {
    let mut map = mapped();
    let get = map.prepare(TransferKind::Get, "lp1", 5).unwrap();
    assert_eq!(get.wafer, WaferId(5));
    assert_eq!(get.station.as_str(), "LP1");
    map.begin(get).unwrap();
    // Until commit the wafer is still at its source.
    assert_eq!(map.wafer_at(&at("LP1", 5)), Some(WaferId(5)));
    assert_eq!(map.hand(), None);
    assert_eq!(map.pending(), Some(&get));
    assert!(map.wafers_line().ends_with(" pending=get:LP1.5:W5"));
    assert_eq!(map.commit().unwrap(), get);
    assert_eq!(map.hand(), Some(WaferId(5)));
    assert_eq!(map.slot("LP1", 5).unwrap(), SlotState::Empty);

    let put = map.prepare(TransferKind::Put, "PM2", 1).unwrap();
    map.begin(put).unwrap();
    assert_eq!(map.abort().unwrap(), put);
    assert_eq!(map.hand(), Some(WaferId(5)));
    map.begin(put).unwrap();
    map.commit().unwrap();
    assert_eq!(map.wafer_at(&at("PM2", 1)), Some(WaferId(5)));
    assert_eq!(map.hand(), None);
    assert_eq!(
        map.wafers_line(),
        "hand=- LP1=W1..W4,-,W6..W25 LP2=-x25 AL=- PM1=- PM2=W5 BF1=?x5"
    );
    map.verify().unwrap();
}

#[test]
fn every_refusal_leaves_the_map_unchanged() {
    let mut map = mapped();
    let check =
        |map: &mut WaferMap, f: &dyn Fn(&mut WaferMap) -> Result<(), WaferMapError>, want: &str| {
            let before = map.clone();
            let e = f(map).unwrap_err();
            assert_eq!(*map, before, "{e}");
            let msg = e.to_string();
            assert!(msg.contains(want), "{msg} lacks {want}");
        };
    let get = |st: &'static str, slot: u16| {
        move |m: &mut WaferMap| m.prepare(TransferKind::Get, st, slot).map(|_| ())
    };
    let put = |st: &'static str, slot: u16| {
        move |m: &mut WaferMap| m.prepare(TransferKind::Put, st, slot).map(|_| ())
    };
    check(
        &mut map,
        &get("LP2", 1),
        "no GET from LP2 slot 1: the wafer map says it is empty",
    );
    check(
        &mut map,
        &put("PM1", 1),
        "no PUT: the wafer map says the hand holds no wafer",
    );
    check(&mut map, &get("LP7", 1), "no station named \"LP7\"");
    check(&mut map, &get("LP1", 26), "LP1 has no slot 26");
    check(&mut map, &get("LP1", 0), "has no slot 0");
    check(
        &mut map,
        &|m| m.commit().map(|_| ()),
        "no transfer is pending",
    );
    check(
        &mut map,
        &|m| m.abort().map(|_| ()),
        "no transfer is pending",
    );
    let wrong = Transfer {
        kind: TransferKind::Get,
        station: name("LP1"),
        slot: 1,
        wafer: WaferId(2),
        blade: Blade::A,
    };
    check(
        &mut map,
        &move |m| m.begin(wrong),
        "names wafer W2, but LP1.1 holds W1",
    );

    // A wafer on the hand: no GET, and no PUT into an occupied slot.
    let t = map.prepare(TransferKind::Get, "LP1", 1).unwrap();
    map.begin(t).unwrap();
    check(
        &mut map,
        &get("LP1", 2),
        "transfer GET LP1 1 (W1) is still pending",
    );
    check(
        &mut map,
        &|m| m.place(Location::HAND, WaferId(99)),
        "still pending",
    );
    check(
        &mut map,
        &|m| m.remove(Location::HAND).map(|_| ()),
        "still pending",
    );
    check(
        &mut map,
        &|m| m.apply_mapping("LP2", &[SlotCode::Absent; 25]).map(|_| ()),
        "still pending",
    );
    map.commit().unwrap();
    check(&mut map, &get("LP1", 2), "the hand already holds wafer W1");
    check(
        &mut map,
        &put("LP1", 2),
        "LP1 slot 2 already holds wafer W2",
    );

    // Faulty and unknown slots.
    let mut codes = vec![SlotCode::Absent; 25];
    codes[0] = SlotCode::Double;
    codes[1] = SlotCode::Cross;
    map.apply_mapping("LP2", &codes).unwrap();
    check(&mut map, &put("LP2", 1), "LP2 slot 1 has a double wafer");
    check(&mut map, &put("LP2", 2), "cross-slotted");
    let mut fresh = WaferMap::new(&demo());
    check(&mut fresh, &put("PM1", 1), "has not been mapped");

    // Place and remove.
    check(
        &mut map,
        &|m| m.place(at("LP2", 3), WaferId(2)),
        "wafer W2 is already in the map, at LP1.2",
    );
    check(
        &mut map,
        &|m| m.place(at("LP1", 3), WaferId(90)),
        "LP1 slot 3 already holds wafer W3",
    );
    check(
        &mut map,
        &|m| m.place(Location::HAND, WaferId(90)),
        "the hand already holds wafer W1",
    );
    check(&mut map, &|m| m.place(at("LP2", 1), WaferId(90)), "double");
    check(
        &mut map,
        &|m| m.remove(at("LP2", 5)).map(|_| ()),
        "LP2.5 holds no wafer",
    );
    check(
        &mut map,
        &|m| m.remove(at("LP2", 1)).map(|_| ()),
        "holds no wafer",
    );
}

#[test]
fn place_and_remove_keep_ids_unique_and_fresh() {
    let mut map = mapped();
    map.place(at("PM1", 1), WaferId(100)).unwrap();
    assert_eq!(map.new_id().unwrap(), WaferId(101));
    assert_eq!(map.remove(at("PM1", 1)).unwrap(), WaferId(100));
    assert_eq!(map.slot("PM1", 1).unwrap(), SlotState::Empty);
    // Placing into an unknown slot makes it known.
    let mut fresh = WaferMap::new(&demo());
    fresh.place(at("AL", 1), WaferId(1)).unwrap();
    assert_eq!(fresh.slot("AL", 1).unwrap(), SlotState::Wafer(WaferId(1)));
    fresh.place(Location::HAND, WaferId(u32::MAX)).unwrap();
    assert!(matches!(fresh.new_id(), Err(WaferMapError::IdsExhausted)));
    assert!(matches!(
        fresh.apply_mapping("PM1", &[SlotCode::Present]),
        Err(WaferMapError::IdsExhausted)
    ));
    fresh.verify().unwrap();
    assert_eq!(WaferMap::from_text(&fresh.to_text(), "m").unwrap(), fresh);
}

#[test]
fn a_wafer_on_the_hand_is_uncertain_until_a_sensor_or_an_operator_settles_it() {
    let mut holding = mapped();
    let get = holding.prepare(TransferKind::Get, "LP1", 7).unwrap();
    holding.begin(get).unwrap();
    holding.commit().unwrap();

    // The board stops answering: the wafer stays on the hand, uncertain, and is saved so.
    let mut m = holding.clone();
    assert_eq!(m.mark_uncertain(), 1);
    assert_eq!(m.mark_uncertain(), 0, "already uncertain");
    assert!(m.is_uncertain(Blade::A) && !m.is_uncertain(Blade::B));
    assert_eq!(m.hand(), Some(WaferId(7)), "not lost, not moved");
    assert!(
        m.wafers_line().starts_with("hand=W7? "),
        "{}",
        m.wafers_line()
    );
    let text = m.to_text();
    assert!(text.contains("hand_uncertain = true"), "{text}");
    let back = WaferMap::from_text(&text, "m").unwrap();
    assert_eq!(back, m);

    // Back on a board that senses it: certain again.
    let mut sensed = m.clone();
    assert_eq!(sensed.reconcile([true, false]), Reconciled::Consistent);
    assert_eq!(sensed, holding);
    // One that does not: reported, and still uncertain (an operator must look).
    let mut unsensed = m.clone();
    assert_eq!(
        unsensed.reconcile([false, false]),
        Reconciled::HandWaferNotSensed(Blade::A, WaferId(7))
    );
    assert!(unsensed.is_uncertain(Blade::A));
    // The operator removes it (or places it again): settled.
    unsensed.remove(Location::HAND).unwrap();
    assert!(!unsensed.is_uncertain(Blade::A));

    // The vacuum sensor lost the wafer in motion: that blade only, and only with a wafer.
    let mut lost = holding.clone();
    assert!(lost.mark_blade_uncertain(Blade::A));
    assert!(lost.is_uncertain(Blade::A) && !lost.is_uncertain(Blade::B));
    assert!(
        !lost.mark_blade_uncertain(Blade::B),
        "blade B holds nothing"
    );
    assert!(!lost.is_uncertain(Blade::B));
    assert_eq!(lost, m, "the same uncertainty as a lost board's");

    // A pending transfer stays pending; an empty hand has nothing to be uncertain about.
    let mut pending = mapped();
    pending.begin(get).unwrap();
    assert_eq!(pending.mark_uncertain(), 0);
    assert_eq!(pending.pending(), Some(&get));
    assert_eq!(pending.reconcile([true, false]), Reconciled::Committed(get));
    assert!(!pending.is_uncertain(Blade::A));
}

#[test]
fn reconcile_resolves_a_pending_transfer_from_the_vacuum_sensor() {
    let base = mapped();
    let get = base.prepare(TransferKind::Get, "LP1", 7).unwrap();

    let mut m = base.clone();
    m.begin(get).unwrap();
    assert_eq!(m.reconcile([true, false]), Reconciled::Committed(get));
    assert_eq!(m.hand(), Some(WaferId(7)));

    let mut m = base.clone();
    m.begin(get).unwrap();
    assert_eq!(m.reconcile([false, false]), Reconciled::Aborted(get));
    assert_eq!(m, base);

    let mut holding = base.clone();
    holding.begin(get).unwrap();
    holding.commit().unwrap();
    let put = holding.prepare(TransferKind::Put, "AL", 1).unwrap();

    let mut m = holding.clone();
    m.begin(put).unwrap();
    assert_eq!(m.reconcile([true, false]), Reconciled::Aborted(put));
    assert_eq!(m, holding);

    let mut m = holding.clone();
    m.begin(put).unwrap();
    let r = m.reconcile([false, false]);
    assert_eq!(r, Reconciled::Committed(put));
    assert!(r.is_consistent());
    assert_eq!(m.wafer_at(&at("AL", 1)), Some(WaferId(7)));

    // Nothing pending: compare the hand.
    let mut m = base.clone();
    assert_eq!(m.reconcile([false, false]), Reconciled::Consistent);
    assert_eq!(
        m.reconcile([true, false]),
        Reconciled::UnknownWaferOnHand(Blade::A)
    );
    let mut m = holding.clone();
    assert_eq!(m.reconcile([true, false]), Reconciled::Consistent);
    let r = m.reconcile([false, false]);
    assert_eq!(r, Reconciled::HandWaferNotSensed(Blade::A, WaferId(7)));
    assert!(!r.is_consistent());
    assert_eq!(m, holding);
}

#[test]
fn adopting_changed_stations_never_drops_a_wafer() {
    let mut map = mapped();
    let mut stations = demo();
    // A new station appears unknown; renaming case follows the file.
    let mut bf = stations.get("AL").unwrap().clone();
    bf.name = name("BUF");
    bf.kind = crate::StationKind::Buffer;
    let mut list = stations.as_slice().to_vec();
    list.push(bf);
    list[3].name = name("pm1");
    stations = Stations::from_list(list.clone()).unwrap();
    map.adopt_stations(&stations).unwrap();
    assert_eq!(map.slot("BUF", 1).unwrap(), SlotState::Unknown);
    assert_eq!(map.station_names().nth(3).unwrap().as_str(), "pm1");

    // LP1 shrinking to 20 slots would drop W21..W25: refused, nothing changes.
    let before = map.clone();
    let mut shrunk = list.clone();
    shrunk[0].slots = 20;
    shrunk[0].sim = None;
    let e = map
        .adopt_stations(&Stations::from_list(shrunk).unwrap())
        .unwrap_err();
    assert!(e.to_string().contains("LP1.21 holds wafer W21"), "{e}");
    assert_eq!(map, before);

    // Removing LP1 entirely: refused too. Removing the empty LP2: fine.
    let without_lp1 = Stations::from_list(list[1..].to_vec()).unwrap();
    assert!(map.adopt_stations(&without_lp1).is_err());
    let mut without_lp2 = list.clone();
    without_lp2.remove(1);
    map.adopt_stations(&Stations::from_list(without_lp2.clone()).unwrap())
        .unwrap();
    assert!(map.slots("LP2").is_none());

    // A pending transfer's slot cannot go away, even when it is empty (a PUT).
    let t = map.prepare(TransferKind::Get, "LP1", 1).unwrap();
    map.begin(t).unwrap();
    map.commit().unwrap();
    map.apply_mapping("BUF", &[SlotCode::Absent]).unwrap();
    let put = map.prepare(TransferKind::Put, "BUF", 1).unwrap();
    map.begin(put).unwrap();
    let mut no_buf = without_lp2.clone();
    no_buf.pop();
    let e = map
        .adopt_stations(&Stations::from_list(no_buf).unwrap())
        .unwrap_err();
    assert!(
        e.to_string().contains("BUF.1 holds the pending transfer"),
        "{e}"
    );
    map.verify().unwrap();
}

#[test]
fn the_text_form_round_trips_and_names_its_version() {
    let mut map = mapped();
    let t = map.prepare(TransferKind::Get, "LP1", 2).unwrap();
    map.begin(t).unwrap();
    let text = map.to_text();
    assert!(
        text.contains("version = 3") && text.contains("[pending]"),
        "{text}"
    );
    assert_eq!(WaferMap::from_text(&text, "m.toml").unwrap(), map);
    map.commit().unwrap();
    let text = map.to_text();
    assert!(
        text.contains("hand = \"W2\"") && !text.contains("[pending]"),
        "{text}"
    );
    assert_eq!(WaferMap::from_text(&text, "m.toml").unwrap(), map);
    let empty = WaferMap::default();
    assert_eq!(WaferMap::from_text(&empty.to_text(), "m").unwrap(), empty);
}

#[test]
fn corrupt_files_are_errors_never_an_empty_map() {
    let good = {
        let mut m = mapped();
        let t = m.prepare(TransferKind::Get, "LP1", 1).unwrap();
        m.begin(t).unwrap();
        m.to_text()
    };
    let bad = |text: &str, want: &str| {
        let e = WaferMap::from_text(text, "wafers.toml").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("wafers.toml") && msg.contains(want),
            "{msg} lacks {want}"
        );
    };
    let with = |from: &str, to: &str| {
        assert!(good.contains(from), "{from}");
        good.replacen(from, to, 1)
    };
    bad("", "no format version");
    bad(
        "version = 4\nwhatever = 1\n",
        "format version 4; this wrc reads versions 1 to 3",
    );
    bad("version = \"one\"", "version");
    bad("version = 1\nnext_id = 1\n[[station]\n", "line 3");
    bad(&with("next_id = 26", "next_id = 26\ncolour = 1"), "colour");
    bad(&with("next_id = 26", "next_id = 0"), "next_id = 0");
    bad(
        &with("next_id = 26", "next_id = 25"),
        "wafer W25 at LP1.25 is not below next_id 25",
    );
    bad(
        &with("\"W3\"", "\"W2\""),
        "wafer W2 is both at LP1.2 and at LP1.3",
    );
    bad(
        &with("\"W3\"", "\"three\""),
        "station LP1 slot 3: \"three\" is not a slot state",
    );
    bad(
        &with("kind = \"get\"", "kind = \"grab\""),
        "pending.kind \"grab\"",
    );
    bad(
        &with("wafer = \"W1\"", "wafer = \"W2\""),
        "the pending transfer GET LP1 1 (W2) does not match the map",
    );
    bad(&with("slot = 1", "slot = 70000"), "pending.slot 70000");
    bad(&with("slot = 1", "slot = 40"), "LP1 has no slot 40");
    bad(
        &with("name = \"LP2\"", "name = \"lp1\""),
        "station lp1 is listed twice",
    );
    bad(
        &with("name = \"AL\"", "name = \"A L\""),
        "not a usable station name",
    );
    bad(
        &with("next_id = 26", "next_id = 26\nhand = \"W1\""),
        "wafer W1 is both at LP1.1 and at hand",
    );
    bad(
        &with("next_id = 26", "next_id = 26\nhand = \"nobody\""),
        "hand: \"nobody\"",
    );
    bad(
        "version = 1\nnext_id = 1\n[[station]]\nname = \"A\"\nslots = []\n",
        "station A has 0 slots",
    );
}

/// Regression (found by `wrc bench faults`): a wafer map cut at the end of a line is
/// still valid TOML. Cut before the stations, the controller took every slot as unknown and
/// wrote the map back, forgetting 24 wafers; cut before `[pending]` or `hand`, it lost the
/// transfer under way or the hand's wafer. Every cut short of the end line is refused.
#[test]
fn a_map_cut_at_any_line_is_refused_and_a_version_1_map_is_still_read() {
    let mut map = mapped();
    let t = map.prepare(TransferKind::Get, "LP1", 4).unwrap();
    map.begin(t).unwrap();
    map.commit().unwrap();
    let t = map.prepare(TransferKind::Put, "LP2", 1).unwrap();
    map.begin(t).unwrap();
    let text = map.to_text();
    assert!(text.ends_with(&format!("\n{END_LINE}\n")), "{text}");
    let mut cuts = 0;
    for (at, _) in text.match_indices('\n') {
        let cut = &text[..=at];
        if cut == text {
            continue;
        }
        let e = WaferMap::from_text(cut, "wafers.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("wafers.toml"), "{e}");
        if e.contains("cut short") {
            cuts += 1;
        }
    }
    assert!(cuts >= 4, "valid TOML cut short at {cuts} lines");
    // Blank lines or spaces after the end line are not a cut.
    assert_eq!(
        WaferMap::from_text(&format!("{text}\n  \n"), "wafers.toml").unwrap(),
        map
    );
    // A file of an earlier wrc (version 1, no end line; version 2) is read, and written as
    // version 3.
    let old = text
        .replace("version = 3", "version = 1")
        .replace(&format!("\n{END_LINE}\n"), "\n");
    let read = WaferMap::from_text(&old, "wafers.toml").unwrap();
    assert_eq!(read, map);
    assert!(read.to_text().contains("version = 3"));
    let two = text.replace("version = 3", "version = 2");
    assert_eq!(WaferMap::from_text(&two, "wafers.toml").unwrap(), map);
}

#[test]
fn load_and_save() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wafers.toml");
    // Missing file: an empty map, ready to adopt the stations.
    let mut map = WaferMap::load(&path).unwrap();
    assert_eq!(map, WaferMap::default());
    map.adopt_stations(&demo()).unwrap();
    assert_eq!(map, WaferMap::new(&demo()));
    let map = mapped();
    map.save_atomic(&path).unwrap();
    assert_eq!(WaferMap::load(&path).unwrap(), map);
    assert!(!dir.path().join("wafers.toml.tmp").exists());
    // A truncated file (as a non-atomic write could leave) is an error.
    let text = map.to_text();
    std::fs::write(&path, &text[..text.len() / 2]).unwrap();
    assert!(matches!(
        WaferMap::load(&path),
        Err(WaferMapError::Corrupt { .. })
    ));
    // Unreadable: a directory.
    let e = WaferMap::load(dir.path()).unwrap_err();
    assert!(matches!(e, WaferMapError::Read { .. }), "{e}");
    let e = map
        .save_atomic(&dir.path().join("no/such/dir.toml"))
        .unwrap_err();
    assert!(e.to_string().contains("previous file is unchanged"), "{e}");
}

#[test]
fn wafers_line_compresses_runs_and_fits_a_protocol_line() {
    let s = |v: &[SlotState]| compact_slots(v);
    let w = |n| SlotState::Wafer(WaferId(n));
    assert_eq!(s(&[w(1), w(2)]), "W1,W2");
    assert_eq!(s(&[w(1), w(2), w(3)]), "W1..W3");
    assert_eq!(s(&[w(3), w(2), w(1)]), "W3,W2,W1");
    assert_eq!(
        s(&[w(1), w(2), w(3), w(5), w(6), w(7), w(8)]),
        "W1..W3,W5..W8"
    );
    assert_eq!(
        s(&[
            SlotState::Empty,
            SlotState::Empty,
            SlotState::Unknown,
            SlotState::Fault(SlotFault::Double),
            SlotState::Fault(SlotFault::Double),
            SlotState::Fault(SlotFault::Cross)
        ]),
        "-x2,?,Dx2,X"
    );
    assert_eq!(
        s(&[w(u32::MAX - 1), w(u32::MAX), w(0)]),
        "W4294967294,W4294967295,W0"
    );
    // Read back: every list above is the slots it was made of.
    for slots in [
        vec![w(1), w(2), w(3), w(5), w(6), w(7), w(8)],
        vec![w(3), w(2), w(1), SlotState::Empty],
        vec![
            SlotState::Empty,
            SlotState::Empty,
            SlotState::Unknown,
            SlotState::Fault(SlotFault::Double),
            SlotState::Fault(SlotFault::Double),
            SlotState::Fault(SlotFault::Cross),
        ],
        vec![w(u32::MAX - 1), w(u32::MAX), w(0)],
    ] {
        assert_eq!(parse_slot_list(&s(&slots)), Some(slots));
    }
    for bad in ["", "W3..W1", "-x0", "Q", "Wx2", "W1..", "-x", "W1,,W2"] {
        assert_eq!(parse_slot_list(bad), None, "{bad:?}");
    }

    // Worst case for the demo cell: every place full, no run compresses, 5-digit ids, plus
    // the longest pending transfer: within the documented 462 bytes.
    let mut map = WaferMap::new(&demo());
    let mut next = 10_000u32;
    for st in ["LP1", "LP2", "AL", "PM1", "PM2", "BF1"] {
        for slot in 1..=map.slots(st).unwrap().len() as u16 {
            map.place(at(st, slot), WaferId(next)).unwrap();
            next += 2;
        }
    }
    let full = map.wafers_line();
    assert!(full.len() <= 462 - 26, "{} bytes: {full}", full.len());
    map.remove(at("LP2", 25)).unwrap();
    map.place(Location::HAND, WaferId(99_999)).unwrap();
    let put = map.prepare(TransferKind::Put, "LP2", 25).unwrap();
    map.begin(put).unwrap();
    // ... with the wafer on the hand uncertain (the board stopped answering).
    assert_eq!(map.mark_uncertain(), 1);
    let line = map.wafers_line();
    assert!(line.len() <= 462, "{} bytes: {line}", line.len());
    assert!(line.starts_with("hand=W99999? "), "{line}");
    assert!(line.ends_with(" pending=put:LP2.25:W99999"), "{line}");
    let lines = map.wafers_lines();
    assert_eq!(lines.len(), 8);
    assert_eq!(lines.join(" "), line);
}

// ---- property tests -------------------------------------------------------------------

#[derive(Debug, Clone)]
enum Op {
    /// GET (true) or PUT from/to the n-th station, slot chosen modulo its slot count.
    Begin(bool, usize, u16),
    /// GET from the n-th occupied slot or PUT into the n-th empty one: likely to succeed.
    BeginValid(usize),
    Commit,
    Abort,
    Reconcile(bool),
    /// Save the map (atomically: the whole text).
    Save,
    /// Kill -9: only the last saved text survives; changes since are gone.
    Crash,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (any::<bool>(), 0usize..5, 1u16..30).prop_map(|(g, s, n)| Op::Begin(g, s, n)),
        (0usize..60).prop_map(Op::BeginValid),
        Just(Op::Commit),
        Just(Op::Abort),
        any::<bool>().prop_map(Op::Reconcile),
        Just(Op::Save),
        Just(Op::Crash),
    ]
}

fn codes(n: usize) -> impl Strategy<Value = Vec<SlotCode>> {
    proptest::collection::vec(
        prop_oneof![
            4 => Just(SlotCode::Present),
            4 => Just(SlotCode::Absent),
            1 => Just(SlotCode::Double),
            1 => Just(SlotCode::Cross),
        ],
        n,
    )
}

fn names() -> [&'static str; 5] {
    ["LP1", "LP2", "AL", "PM1", "PM2"]
}

fn seeded(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(0x8_2024),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(seeded(256))]

    /// Over any sequence of begin/commit/abort/reconcile, saves and crashes (the map is
    /// rebuilt from its last saved text, losing what was not saved), the set of ids never changes: no id lost, none duplicated;
    /// a refused operation changes nothing; the saved text always reads back.
    #[test]
    fn transfers_and_crashes_never_lose_or_duplicate_a_wafer(
        lp1 in codes(25), lp2 in codes(25), singles in codes(3),
        ops in proptest::collection::vec(op(), 1..80),
    ) {
        let stations = demo();
        let mut map = WaferMap::new(&stations);
        map.apply_mapping("LP1", &lp1).unwrap();
        map.apply_mapping("LP2", &lp2).unwrap();
        for (s, c) in ["AL", "PM1", "PM2"].into_iter().zip(&singles) {
            map.apply_mapping(s, &[*c]).unwrap();
        }
        let initial = ids(&map);
        let mut saved = map.to_text();
        for op in ops {
            let before = map.clone();
            let result: Result<(), WaferMapError> = match op {
                Op::Begin(get, s, n) => {
                    let st = names()[s];
                    let slots = map.slots(st).unwrap().len() as u16;
                    let kind = if get { TransferKind::Get } else { TransferKind::Put };
                    map.prepare(kind, st, (n - 1) % slots + 1).and_then(|t| map.begin(t))
                }
                Op::BeginValid(n) => {
                    let want = if map.hand().is_some() { SlotState::Empty } else { SlotState::Wafer(WaferId(0)) };
                    let places: Vec<(StationName, u16)> = map.station_names().flat_map(|st| {
                        map.slots(st.as_str()).unwrap().iter().enumerate().filter(|(_, s)| match (s, want) {
                            (SlotState::Wafer(_), SlotState::Wafer(_)) => true,
                            (a, b) => **a == b,
                        }).map(move |(i, _)| (st, i as u16 + 1)).collect::<Vec<_>>()
                    }).collect();
                    if places.is_empty() {
                        Ok(())
                    } else {
                        let (st, slot) = places[n % places.len()];
                        let kind = if map.hand().is_some() { TransferKind::Put } else { TransferKind::Get };
                        map.prepare(kind, st.as_str(), slot).and_then(|t| map.begin(t))
                    }
                }
                Op::Commit => map.commit().map(|_| ()),
                Op::Abort => map.abort().map(|_| ()),
                Op::Reconcile(sensed) => {
                    let r = map.reconcile([sensed, false]);
                    if let Reconciled::Committed(t) = r {
                        prop_assert_eq!(map.wafer_at(&t.destination()), Some(t.wafer));
                    }
                    if let Reconciled::Aborted(t) = r {
                        prop_assert_eq!(map.wafer_at(&t.source()), Some(t.wafer));
                    }
                    Ok(())
                }
                Op::Save => {
                    saved = map.to_text();
                    Ok(())
                }
                Op::Crash => {
                    map = WaferMap::from_text(&saved, "wafers.toml").unwrap();
                    Ok(())
                }
            };
            if result.is_err() {
                prop_assert_eq!(&map, &before);
            }
            prop_assert_eq!(&WaferMap::from_text(&map.to_text(), "wafers.toml").unwrap(), &map);
            map.verify().unwrap();
            prop_assert_eq!(ids(&map), initial.clone());
        }
    }

    /// Mapping, placing and removing on top of transfers: the map's rules always hold and
    /// ids are never reused.
    #[test]
    fn every_operation_keeps_the_rules(
        ops in proptest::collection::vec((0u8..9, 0usize..5, 1u16..30, codes(25), any::<bool>()), 1..60),
    ) {
        let stations = demo();
        let mut map = WaferMap::new(&stations);
        map.set_dual(true);
        let mut ever: Vec<WaferId> = Vec::new();
        for (kind, s, n, codes, b) in ops {
            let st = names()[s];
            let slots = map.slots(st).unwrap().len();
            let slot = (n - 1) % slots as u16 + 1;
            // Either blade: a dual-blade robot's map keeps the same rules.
            let blade = if b { Blade::B } else { Blade::A };
            let before = map.clone();
            let result = match kind {
                0 => map.apply_mapping(st, &codes[..slots]).map(|_| ()),
                1 => map.new_id().and_then(|id| map.place(at(st, slot), id)),
                2 => map.remove(at(st, slot)).map(|_| ()),
                3 => map.prepare_blade(TransferKind::Get, st, slot, blade).and_then(|t| map.begin(t)),
                4 => map.prepare_blade(TransferKind::Put, st, slot, blade).and_then(|t| map.begin(t)),
                5 => map.commit().map(|_| ()),
                6 => map.new_id().and_then(|id| map.place(Location::Hand(blade), id)),
                7 => map.remove(Location::Hand(blade)).map(|_| ()),
                _ => { map.reconcile([n % 2 == 0, b]); Ok(()) }
            };
            // A refused place has still handed out its new id (kinds 1 and 6).
            if result.is_err() && kind != 1 && kind != 6 {
                prop_assert_eq!(&map, &before);
            }
            map.verify().unwrap();
            for (_, w) in map.iter() {
                if !ever.contains(&w) {
                    // A new id is above every id ever seen.
                    prop_assert!(ever.iter().all(|e| *e < w), "{} reused", w);
                    ever.push(w);
                }
            }
            // The blade count is the robot's, not the file's.
            let mut back = WaferMap::from_text(&map.to_text(), "m").unwrap();
            back.set_dual(true);
            prop_assert_eq!(back, map.clone());
        }
    }

    /// Arbitrary text never panics the parser.
    #[test]
    fn any_text_parses_or_errs(text in "\\PC{0,200}") {
        let _ = WaferMap::from_text(&text, "m");
    }
}

fn slot_state() -> impl Strategy<Value = SlotState> {
    prop_oneof![
        Just(SlotState::Unknown),
        Just(SlotState::Empty),
        Just(SlotState::Fault(SlotFault::Double)),
        Just(SlotState::Fault(SlotFault::Cross)),
        // Few ids, so that rising runs of 3 and more come often.
        (1u32..6).prop_map(|n| SlotState::Wafer(WaferId(n))),
    ]
}

proptest! {
    #![proptest_config(seeded(512))]

    /// A station's `WAFERS` list reads back as the slots it was written from.
    #[test]
    fn a_slot_list_reads_back_as_its_slots(slots in proptest::collection::vec(slot_state(), 1..30)) {
        prop_assert_eq!(parse_slot_list(&compact_slots(&slots)), Some(slots));
    }
}

#[test]
fn a_slot_states_code_is_what_a_map_of_it_reports() {
    assert_eq!(SlotState::Unknown.code(), None);
    assert_eq!(SlotState::Empty.code(), Some(SlotCode::Absent));
    assert_eq!(SlotState::Wafer(WaferId(9)).code(), Some(SlotCode::Present));
    for fault in [SlotFault::Double, SlotFault::Cross] {
        assert_eq!(SlotState::Fault(fault).code(), Some(fault.code()));
    }
}

/// A dual-blade robot: each blade is its own hand place, a transfer names its blade, and the
/// blade survives the file, the `WAFERS` line and start-up reconciliation.
#[test]
fn blade_b_is_a_hand_place_of_its_own() {
    let mut map = mapped();
    assert!(!map.wafers_line().contains("hand.B"));
    map.set_dual(true);
    assert!(map.wafers_line().starts_with("hand=- hand.B=- LP1="));
    // GET LP1 1 with blade B, then LP1 2 with blade A: both blades full.
    let get_b = map
        .prepare_blade(TransferKind::Get, "LP1", 1, Blade::B)
        .unwrap();
    assert_eq!(get_b.destination(), Location::Hand(Blade::B));
    assert_eq!(get_b.to_string(), "GET LP1 1 B (W1)");
    map.begin(get_b).unwrap();
    assert!(map.wafers_line().ends_with("pending=get:LP1.1:W1:B"));
    // The pending transfer and its blade survive a save and a load.
    let text = map.to_text();
    assert!(text.contains("blade = \"B\""), "{text}");
    let mut back = WaferMap::from_text(&text, "m").unwrap();
    back.set_dual(true);
    assert_eq!(back, map);
    map.commit().unwrap();
    assert_eq!(map.hand_of(Blade::B), Some(WaferId(1)));
    assert_eq!(map.hand(), None);
    // Blade B is full: it cannot GET again, but blade A can.
    assert!(matches!(
        map.prepare_blade(TransferKind::Get, "LP1", 2, Blade::B),
        Err(WaferMapError::HandOccupied { wafer: WaferId(1) })
    ));
    let get_a = map.prepare(TransferKind::Get, "LP1", 2).unwrap();
    map.begin(get_a).unwrap();
    map.commit().unwrap();
    assert!(map.wafers_line().starts_with("hand=W2 hand.B=W1 "));
    assert_eq!(map.location_of(WaferId(1)), Some(Location::Hand(Blade::B)));
    assert_eq!(Location::Hand(Blade::B).to_string(), "hand.B");
    // PUT with blade B gives W1, not blade A's W2.
    let put_b = map
        .prepare_blade(TransferKind::Put, "PM1", 1, Blade::B)
        .unwrap();
    assert_eq!(put_b.wafer, WaferId(1));
    let text = map.to_text();
    assert!(text.contains("hand_b = \"W1\""), "{text}");
    assert_eq!(
        WaferMap::from_text(&text, "m").unwrap().hand_of(Blade::B),
        Some(WaferId(1))
    );
    map.verify().unwrap();
    // A load without set_dual still shows blade B's wafer.
    assert!(WaferMap::from_text(&text, "m")
        .unwrap()
        .wafers_line()
        .contains("hand.B=W1"));
    // A bad blade in the file is named.
    let bad = text.replacen("[[station]]", "[pending]\nkind = \"put\"\nstation = \"PM1\"\nslot = 1\nwafer = \"W1\"\nblade = \"C\"\n\n[[station]]", 1);
    let e = WaferMap::from_text(&bad, "m").unwrap_err().to_string();
    assert!(e.contains("pending.blade \"C\""), "{e}");
}

#[test]
fn reconcile_reads_the_sensor_of_the_pending_transfers_blade() {
    let mut map = mapped();
    map.set_dual(true);
    let a = map.prepare(TransferKind::Get, "LP1", 3).unwrap();
    map.begin(a).unwrap();
    map.commit().unwrap();
    let put_b = map
        .prepare_blade(TransferKind::Get, "LP1", 4, Blade::B)
        .unwrap();
    // Blade B's GET happened (its sensor sees a wafer) while blade A still holds W3.
    let mut m = map.clone();
    m.begin(put_b).unwrap();
    assert_eq!(m.reconcile([true, true]), Reconciled::Committed(put_b));
    assert_eq!(m.hand_of(Blade::B), Some(WaferId(4)));
    // It had not happened: blade B's sensor is off; blade A's wafer is not involved.
    let mut m = map.clone();
    m.begin(put_b).unwrap();
    assert_eq!(m.reconcile([true, false]), Reconciled::Aborted(put_b));
    assert_eq!(m.hand_of(Blade::B), None);
    assert_eq!(m.hand(), Some(WaferId(3)));
    // Without a pending transfer, each blade is compared with its sensor.
    assert_eq!(map.reconcile([true, false]), Reconciled::Consistent);
    assert_eq!(
        map.reconcile([true, true]),
        Reconciled::UnknownWaferOnHand(Blade::B)
    );
    assert_eq!(
        map.reconcile([false, false]),
        Reconciled::HandWaferNotSensed(Blade::A, WaferId(3))
    );
}

/// `mapped()` with GET LP1 3 pending (or, with `put`, W3 on the hand and PUT LP2 1 pending).
fn interrupted(put: bool) -> (WaferMap, Transfer) {
    let mut map = mapped();
    let get = map.prepare(TransferKind::Get, "LP1", 3).unwrap();
    map.begin(get).unwrap();
    if !put {
        return (map, get);
    }
    map.commit().unwrap();
    let t = map.prepare(TransferKind::Put, "LP2", 1).unwrap();
    map.begin(t).unwrap();
    (map, t)
}

#[test]
fn an_interrupted_transfer_settles_as_judged_and_never_drops_an_id_unasked() {
    use crate::journal::Maybe::*;
    for put in [false, true] {
        for (blade, slot) in [
            (Yes, No),
            (No, Yes),
            (Perhaps, Perhaps),
            (Perhaps, No),
            (No, Perhaps),
            (No, No),
            (Yes, Perhaps),
        ] {
            let (mut map, t) = interrupted(put);
            let r = map.settle_interrupted(blade, slot).unwrap();
            map.verify().unwrap();
            assert_eq!(map.pending(), None);
            let on_blade = map.hand() == Some(WaferId(3));
            let in_slot = map.slot(t.station.as_str(), t.slot).unwrap();
            let case = format!("{t} {blade:?} {slot:?}: {}", map.wafers_line());
            match (blade, slot) {
                (Yes, _) => {
                    assert!(on_blade && map.is_certain(&Location::HAND), "{case}");
                    assert_eq!(in_slot, SlotState::Empty, "{case}");
                    let want = if put {
                        Interrupted::Aborted(t)
                    } else {
                        Interrupted::Committed(t)
                    };
                    assert_eq!(r, want, "{case}");
                }
                (No, Yes) => {
                    assert!(!on_blade, "{case}");
                    assert_eq!(in_slot, SlotState::Wafer(WaferId(3)), "{case}");
                }
                (No, No) => {
                    assert_eq!(r, Interrupted::Gone(t), "{case}");
                    assert_eq!(map.location_of(WaferId(3)), None, "{case}");
                    assert_eq!(map.len(), 24);
                }
                _ => {
                    assert_eq!(r, Interrupted::Uncertain(t), "{case}");
                    assert!(map.has_uncertain(), "{case}");
                    assert_eq!(on_blade, blade == Perhaps, "{case}");
                    assert_eq!(map.is_uncertain(Blade::A), blade == Perhaps, "{case}");
                    let want = if slot == Perhaps {
                        SlotState::Uncertain(WaferId(3))
                    } else {
                        SlotState::Empty
                    };
                    assert_eq!(in_slot, want, "{case}");
                    // Counted once, however many places it may be in.
                    assert_eq!(map.len(), 25, "{case}");
                }
            }
        }
    }
    // Without a pending transfer there is nothing to settle.
    assert!(mapped().settle_interrupted(No, Yes).is_err());
}

#[test]
fn uncertain_places_show_are_saved_and_are_refused_to_get_and_put() {
    use crate::journal::Maybe::*;
    let (mut map, _) = interrupted(true);
    map.settle_interrupted(Perhaps, Perhaps).unwrap();
    map.set_note("PUT LP2 1 (W3) was interrupted by a power loss");
    assert_eq!(
        map.wafers_line(),
        "hand=W3? LP1=W1,W2,-,W4..W25 LP2=W3?,-x24 AL=- PM1=- PM2=- BF1=?x5"
    );
    let lp2 = map.wafers_lines()[2].clone();
    assert_eq!(
        parse_slot_list(lp2.strip_prefix("LP2=").unwrap()).unwrap()[0],
        SlotState::Uncertain(WaferId(3))
    );
    let text = map.to_text();
    assert!(
        text.contains("\"W3?\"") && text.contains("note = "),
        "{text}"
    );
    assert_eq!(WaferMap::from_text(&text, "m").unwrap(), map);
    assert_eq!(map.uncertain_places().len(), 2);
    // GET and PUT refuse the uncertain places, each with what to do.
    let e = map.prepare(TransferKind::Get, "LP2", 1).unwrap_err();
    assert!(e.to_string().contains("MAP LP2"), "{e}");
    let e = map.prepare(TransferKind::Put, "LP2", 2).unwrap_err();
    assert!(e.to_string().contains("SENSE"), "{e}");
    assert!(matches!(e, WaferMapError::Uncertain { .. }));
    // A certain wafer may not also be elsewhere, even uncertain.
    let mut broken = map.clone();
    broken.hands[0] = None;
    broken.stations[0].slots[0] = SlotState::Uncertain(WaferId(2));
    assert!(broken.verify().is_err());
}

#[test]
fn a_mapping_settles_an_uncertain_slot_and_the_blade_with_it() {
    use crate::journal::Maybe::*;
    // Found in the slot: the blade that perhaps held it is empty.
    let (mut map, _) = interrupted(true);
    map.settle_interrupted(Perhaps, Perhaps).unwrap();
    let mut scan = vec![SlotCode::Absent; 25];
    scan[0] = SlotCode::Present;
    let c = map.apply_mapping("LP2", &scan).unwrap();
    assert_eq!(c.kept, [(1, WaferId(3))]);
    assert_eq!(map.hand(), None);
    assert!(!map.has_uncertain() && map.note().is_none());
    map.verify().unwrap();
    // Not in the slot: it may still be on the blade.
    let (mut map, _) = interrupted(true);
    map.settle_interrupted(Perhaps, Perhaps).unwrap();
    map.set_note("x");
    let c = map.apply_mapping("LP2", &[SlotCode::Absent; 25]).unwrap();
    assert!(c.removed.is_empty());
    assert_eq!(map.hand(), Some(WaferId(3)));
    assert!(map.is_uncertain(Blade::A) && map.note().is_some());
    // Not in the slot, and nowhere else: it leaves the map, reported.
    let (mut map, _) = interrupted(true);
    map.settle_interrupted(No, Perhaps).unwrap();
    let c = map.apply_mapping("LP2", &[SlotCode::Absent; 25]).unwrap();
    assert_eq!(c.removed, [(1, WaferId(3))]);
    assert_eq!(map.len(), 24);
}

#[test]
fn a_blade_is_settled_by_its_sensor_and_a_place_by_an_operators_word() {
    use crate::journal::Maybe::*;
    let uncertain = || {
        let (mut map, _) = interrupted(true);
        map.settle_interrupted(Perhaps, Perhaps).unwrap();
        map
    };
    // The sensor sees it: certain on the blade, the slot empty.
    let mut map = uncertain();
    assert_eq!(
        map.sense_blade(Blade::A, true).unwrap(),
        Sensed::Held(WaferId(3))
    );
    assert_eq!(map.slot("LP2", 1).unwrap(), SlotState::Empty);
    assert!(!map.has_uncertain());
    // It does not: the blade is empty, the slot still perhaps holds it.
    let mut map = uncertain();
    assert_eq!(
        map.sense_blade(Blade::A, false).unwrap(),
        Sensed::NotHere(WaferId(3))
    );
    assert_eq!(
        map.slot("LP2", 1).unwrap(),
        SlotState::Uncertain(WaferId(3))
    );
    // And then not in the slot either (MAP): gone.
    let c = map.apply_mapping("LP2", &[SlotCode::Absent; 25]).unwrap();
    assert_eq!(c.removed, [(1, WaferId(3))]);
    // A blade that holds a wafer nobody knew gets a new id.
    let mut map = mapped();
    assert_eq!(
        map.sense_blade(Blade::A, true).unwrap(),
        Sensed::Unknown(WaferId(26))
    );
    assert_eq!(
        map.sense_blade(Blade::A, false).unwrap(),
        Sensed::Gone(WaferId(26))
    );
    assert_eq!(map.sense_blade(Blade::A, false).unwrap(), Sensed::Empty);

    // CONFIRM W3 LP2 1: there, and not on the blade.
    let mut map = uncertain();
    map.confirm_at(WaferId(3), at("lp2", 1)).unwrap();
    assert_eq!(map.slot("LP2", 1).unwrap(), SlotState::Wafer(WaferId(3)));
    assert_eq!(map.hand(), None);
    map.verify().unwrap();
    // CONFIRM W3 HAND.
    let mut map = uncertain();
    map.confirm_at(WaferId(3), Location::HAND).unwrap();
    assert!(map.is_certain(&Location::HAND));
    assert_eq!(map.slot("LP2", 1).unwrap(), SlotState::Empty);
    // CONFIRM W3 GONE: out of the map from both places.
    let mut map = uncertain();
    assert_eq!(map.confirm_gone(WaferId(3)).unwrap().len(), 2);
    assert_eq!(map.len(), 24);
    assert!(!map.has_uncertain());
    // CONFIRM HAND EMPTY, then CONFIRM LP2 1 EMPTY: the second one drops the wafer.
    let mut map = uncertain();
    assert_eq!(map.confirm_empty(Location::HAND).unwrap(), None);
    assert_eq!(map.confirm_empty(at("LP2", 1)).unwrap(), Some(WaferId(3)));
    assert_eq!(map.len(), 24);
    // Refusals change nothing: another wafer's place, a wafer not in the map.
    let mut map = uncertain();
    let before = map.clone();
    assert!(map.confirm_at(WaferId(3), at("LP1", 1)).is_err());
    assert!(matches!(
        map.confirm_at(WaferId(99), at("LP2", 2)),
        Err(WaferMapError::NotInMap { .. })
    ));
    assert!(map.confirm_gone(WaferId(99)).is_err());
    assert_eq!(map, before);
}

#[test]
fn a_sensed_blade_makes_its_uncertain_wafer_certain_there_and_nowhere_else() {
    // Found by the fuzzer: a wafer perhaps on either blade (a file says so), and blade B's
    // sensor senses one: it is on B, so not on A any more.
    let text = "version = 1\nnext_id = 27\nhand = \"W4\"\nhand_b = \"W4\"\nhand_uncertain = true\nhand_b_uncertain = true\n";
    let mut m = WaferMap::from_text(text, "t.toml").unwrap();
    m.verify().unwrap();
    let _ = m.reconcile([false, true]);
    m.verify().unwrap();
    assert_eq!(
        (m.hand_of(Blade::A), m.hand_of(Blade::B)),
        (None, Some(WaferId(4)))
    );
    assert!(!m.is_uncertain(Blade::B));
    // Perhaps on the hand, perhaps back in its slot (a GET cut by a power loss), and the
    // sensor senses it on the hand: the slot is empty.
    let mut m = mapped();
    let get = m.prepare(TransferKind::Get, "LP1", 7).unwrap();
    m.begin(get).unwrap();
    m.commit().unwrap();
    assert!(m.doubt_back_in_slot(Blade::A, get.slot_location()));
    m.verify().unwrap();
    let _ = m.reconcile([true, false]);
    m.verify().unwrap();
    assert_eq!(m.hand(), Some(WaferId(7)));
    assert!(!m.is_uncertain(Blade::A));
    assert_eq!(m.uncertain_places(), Vec::new());
}
