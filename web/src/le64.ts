// Little-endian 64-bit integers as JS numbers, for the binary formats the GUI reads (the
// simulator datagrams, trace files): exact up to 2^53, rounded to the nearest double beyond
// (as `JSON.parse` would do). hi·2^32 is exact; adding lo rounds once, so a result is the
// correctly rounded value.

const TWO_32 = 4294967296;

/** The `u64` at byte `offset` of `v`. */
export function getU64(v: DataView, offset: number): number {
  return v.getUint32(offset + 4, true) * TWO_32 + v.getUint32(offset, true);
}

/** The `i64` at byte `offset` of `v`. */
export function getI64(v: DataView, offset: number): number {
  return v.getInt32(offset + 4, true) * TWO_32 + v.getUint32(offset, true);
}

/** Write `x` (a non-negative JS integer below 2^53) as a `u64` at byte `offset` of `v`. */
export function setU64(v: DataView, offset: number, x: number): void {
  v.setUint32(offset, x % TWO_32 >>> 0, true);
  v.setUint32(offset + 4, Math.floor(x / TWO_32) >>> 0, true);
}

/** Write `x` (a JS integer of magnitude below 2^53) as an `i64` at byte `offset` of `v`. */
export function setI64(v: DataView, offset: number, x: number): void {
  const hi = Math.floor(x / TWO_32);
  v.setUint32(offset, (x - hi * TWO_32) >>> 0, true);
  v.setInt32(offset + 4, hi, true);
}
