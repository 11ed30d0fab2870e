// The state directory of a controller that lost its power in the middle of a PUT, for the
// recovery test (recovery.spec.mjs): `wrc up --state-dir DIR` then starts as after a power
// loss — its simulated board powers up where the arm stood, seated in LP2 slot 1 with W1 on
// the blade, every output off — finds the PUT interrupted in its transfer journal and the
// vacuum off, and leaves W1 uncertain on the hand and in LP2 slot 1, the hand inside LP2,
// with alarm 216.
//
// - wafers.toml (crates/wrc-cell/src/wafer_map.rs, format version 3): LP1 mapped full but slot 1,
//   LP2 mapped empty, W1 on the hand and the transfer `PUT LP2 1` of W1 pending.
// - journal.wrcj (crates/wrc-cell/src/journal.rs): that PUT's records up to the BEGIN of the
//   approach and the line in, each line `wrcj1 seq=<n> <record> crc=<crc32>` (the hand got
//   to the seat, but its DONE never reached the disk).
// - world.toml (crates/wrc-cell/src/world.rs): the simulated cell's truth, which the board
//   simulates and the map is compared with: W1's wafer (tag 1) on the blade, its vacuum on, as
//   the power went. The board powers up with the vacuum off, so the wafer drops into LP2 slot 1
//   under the seated hand: SENSE finds the hand empty and MAP LP2 finds the wafer in slot 1.
// - board0.dpram (docs/dpram.md): the DPRAM of a board whose encoders stand at the hand seated
//   in LP2 slot 1, lifted (the PUT's pose before the release). Made by one period of
//   `wrc board-sim` with a copy of config/default.toml whose axes' `home` is that pose (a first
//   start puts the encoders at `home`); `wrc up` powers its board up on it with the default
//   configuration, which has the same layout and axes.
//
// The demo cell's stations (config/stations.toml: LP1, LP2 with 25 slots, AL, PM1, PM2 with 1,
// BF1 with 5), which `wrc up` writes into a state directory that has none.

import { spawnSync } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { crc32 } from 'node:zlib';
import { REPO, WRC_BIN } from './settings.mjs';

/** The demo cell's stations and their slot counts, in the stations file's order. */
const STATIONS = [
  ['LP1', 25],
  ['LP2', 25],
  ['AL', 1],
  ['PM1', 1],
  ['PM2', 1],
  ['BF1', 5],
];

/** LP2 slot 1 seated and lifted (support 20 mm + stroke 6 mm), the hand pointing in at 30°: x, y, z [mm], yaw [deg]. */
const SEAT = { x: 294.449, y: 170, z: 26, yaw: 30 };

const list = (tokens) => `[${tokens.map((t) => JSON.stringify(t)).join(', ')}]`;
const repeat = (t, n) => Array.from({ length: n }, () => t);

/** One journal line as `journal_line` writes it: the CRC-32 of everything before ` crc=`. */
export function journalLine(seq, record) {
  const body = `wrcj1 seq=${seq} ${record}`;
  return `${body} crc=${crc32(body).toString(16).padStart(8, '0')}\n`;
}

/** The wafer map: W1 on the hand, being PUT into LP2 slot 1. */
function wafersToml() {
  const slots = {
    LP1: ['-', ...Array.from({ length: 24 }, (_, i) => `W${i + 2}`)],
    LP2: repeat('-', 25),
  };
  let out = `# wrc wafer map: a PUT LP2 1 of W1 that a power loss interrupted (web/e2e/recovery-fixture.mjs)
version = 3
next_id = 26
hand = "W1"

[pending]
kind = "put"
station = "LP2"
slot = 1
wafer = "W1"
`;
  for (const [name, n] of STATIONS) {
    out += `\n[[station]]\nname = "${name}"\nslots = ${list(slots[name] ?? repeat('?', n))}\n`;
  }
  return `${out}\n# end of the wafer map\n`;
}

/**
 * The journal of that PUT (a blended one, blade A: the blade, the interlock, the station's
 * speed, the vacuum check, the approach blended into the line in, the release, the set-down,
 * the release check, the commit, the line out, the speed restored), cut after the BEGIN of the
 * line in: the power went with the hand on its way in, before the release (a release begun at
 * the seat would have put the wafer there: that the journal settles alone).
 */
function journalText() {
  const home = '0,400,0,0';
  const seat = `${SEAT.x},${SEAT.y},${SEAT.z},${SEAT.yaw}`;
  const records = [
    'OPEN put LP2 1 A W1 plan=BLADE.A,INTERLOCK,SPEED,CHECK1,ENTER,VACOFF,LOWER,CHECK0,COMMIT,OUT,SPEED',
    `BEGIN 0 BLADE.A at=${home}`,
    `DONE 0 BLADE.A at=${home}`,
    `BEGIN 1 INTERLOCK at=${home}`,
    `DONE 1 INTERLOCK at=${home}`,
    `BEGIN 2 SPEED at=${home}`,
    `DONE 2 SPEED at=${home}`,
    `BEGIN 3 CHECK1 at=${home}`,
    `DONE 3 CHECK1 at=${home}`,
    `BEGIN 4 ENTER to=${seat} at=${home}`,
  ];
  return records.map((r, i) => journalLine(i + 1, r)).join('');
}

/** The simulated cell: LP1's wafers (tags 2-25) in slots 2-25, tag 1 on the blade (vacuum on) over LP2 slot 1. */
function worldToml() {
  const slots = {
    LP1: ['-', ...Array.from({ length: 24 }, (_, i) => `T${i + 2}`)],
    LP2: repeat('-', 25),
  };
  let out = `version = 1
next_tag = 26
vacuum = true
hand = 1
last_z = ${SEAT.z}
lost = []
faults = 0
`;
  for (const [name, n] of STATIONS) {
    out += `\n[[station]]\nname = "${name}"\nslots = ${list(slots[name] ?? repeat('-', n))}\n`;
  }
  return out;
}

/**
 * The joints [deg, deg, deg, mm] of `pose` for the arm of `config` (two links, the TCP on the
 * wrist axis, yaw = j1 + j2 + j3), with the elbow on the side of its home (j2 > 0).
 */
function seatJoints(config, pose) {
  const link = (k) => Number(new RegExp(`^${k} = ([0-9.]+)`, 'm').exec(config)?.[1]);
  const [l1, l2, hand] = [link('link1_mm'), link('link2_mm'), link('hand_mm')];
  if (!(l1 > 0 && l2 > 0) || hand !== 0) throw new Error('config/default.toml: expected two links and hand_mm = 0');
  const deg = (r) => (r * 180) / Math.PI;
  const r2 = pose.x * pose.x + pose.y * pose.y;
  const t2 = Math.acos((r2 - l1 * l1 - l2 * l2) / (2 * l1 * l2));
  const t1 = Math.atan2(pose.y, pose.x) - Math.atan2(l2 * Math.sin(t2), l1 + l2 * Math.cos(t2));
  const j1 = deg(t1);
  const j2 = deg(t2);
  return [j1, j2, pose.yaw - j1 - j2, pose.z];
}

/** board0.dpram with the encoders at `SEAT` (see the module comment). */
function writeBoard(dir) {
  const config = readFileSync(join(REPO, 'config', 'default.toml'), 'utf8');
  const joints = seatJoints(config, SEAT);
  let axis = 0;
  const seated = config.replace(/^home = .*$/gm, () => `home = ${joints[axis++].toFixed(4)}`);
  if (axis !== joints.length) throw new Error(`config/default.toml: ${axis} axes, expected ${joints.length}`);
  const tmp = mkdtempSync(join(tmpdir(), 'wrc-seat-'));
  try {
    const file = join(tmp, 'seated.toml');
    writeFileSync(file, seated);
    const r = spawnSync(WRC_BIN, ['board-sim', '--config', file, '--dpram', join(dir, 'board0.dpram'), '--periods', '1'], {
      encoding: 'utf8',
      timeout: 30_000,
    });
    if (r.status !== 0) throw new Error(`wrc board-sim (the seated board): ${r.error?.message ?? r.stderr}`);
  } finally {
    rmSync(tmp, { recursive: true, force: true });
  }
}

/** Write the state of a PUT LP2 1 (W1) interrupted by a power loss into `dir`. */
export function writeInterruptedPut(dir) {
  writeFileSync(join(dir, 'wafers.toml'), wafersToml());
  writeFileSync(join(dir, 'journal.wrcj'), journalText());
  writeFileSync(join(dir, 'world.toml'), worldToml());
  writeBoard(dir);
}
