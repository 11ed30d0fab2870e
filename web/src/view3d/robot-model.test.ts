import { describe, expect, it } from 'vitest';
import { bladeStack, sceneZ } from './robot-model';

// The drawing's own dimensions (robot-model.ts) the expectations below rest on [mm].
const HUB_T = 18;
const FORK_T = 7;
const WAFER_R = 150;

describe('bladeStack', () => {
  it('draws a single hand as it always was: one fork on the wrist hub, a bar to its palm', () => {
    for (const none of [null, undefined, Number.NaN]) {
      expect(bladeStack(0, none)).toEqual({
        drop: 0,
        forkA: HUB_T,
        forkB: null,
        bars: [{ x0: 0, x1: -125, z: HUB_T }],
        post: null,
      });
    }
    expect(bladeStack(300, null).bars).toEqual([{ x0: 0, x1: 175, z: HUB_T }]);
  });

  it("puts blade B's fork bladeB mm from the hand's, and the hand's where it always was in the scene", () => {
    for (const [hand, off] of [
      [0, -30],
      [0, 25],
      [320, -30],
    ]) {
      const s = bladeStack(hand, off);
      expect(s.forkB! - s.forkA, `${hand} ${off}`).toBe(off);
      // The arm is drawn `drop` lower, so the hand's fork is raised by as much: its wafer stays at sceneZ.
      expect(s.forkA - s.drop).toBe(HUB_T);
    }
  });

  it('lowers the arm for a blade below the hand, so blade B rests on the wrist hub clear of link 2', () => {
    const s = bladeStack(0, -30);
    expect(s.drop).toBe(30);
    expect(s.forkB).toBe(HUB_T);
    expect(bladeStack(0, 30).drop).toBe(0); // a blade above needs no room below
    expect(bladeStack(0, -1000).drop).toBeLessThan(250); // the base is never drawn away
  });

  it('joins the two forks behind both wafers, from the lower bar to the top of the upper fork', () => {
    for (const hand of [0, 100, 320]) {
      const s = bladeStack(hand, -30);
      const post = s.post!;
      expect(post.x + 14, `hand ${hand}`).toBeLessThan(hand - WAFER_R); // clear of the wafers' edge
      expect(post.z0).toBe(Math.min(s.forkA, s.forkB!));
      expect(post.z1).toBe(Math.max(s.forkA, s.forkB!) + FORK_T);
      const [lower, upper] = s.bars;
      expect(lower.z).toBe(post.z0);
      expect(upper.z).toBe(post.z1 - FORK_T);
      // The lower bar runs from the wrist past the post; the upper from the post to its palm.
      expect(Math.min(lower.x0, lower.x1)).toBeLessThanOrEqual(Math.min(0, post.x));
      expect(Math.max(lower.x0, lower.x1)).toBeGreaterThanOrEqual(Math.max(0, post.x));
      expect([upper.x0, upper.x1].sort((a, b) => a - b)).toEqual([post.x, hand - 125].sort((a, b) => a - b));
    }
  });

  it('leaves the scene height of a TCP z as it was', () => {
    expect(sceneZ(30) - sceneZ(0)).toBe(30);
  });
});
