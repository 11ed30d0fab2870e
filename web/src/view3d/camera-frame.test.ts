import { describe, expect, it } from 'vitest';
import { frameCamera, segmentHitsFootprint, type Footprint } from './camera-frame';
import { isSoftwareRenderer, renderQuality } from './scene';

// The demo cell's load ports and buffer (config/stations.toml), boxes as the view draws them.
const box = (name: string, x: number, y: number, yaw: number): Footprint => ({ name, x, y, yaw, depth: 350, width: 340 });
const LP1 = box('LP1', 309, -179, -30);
const LP2 = box('LP2', 309, 179, 30);
const AL = box('AL', 0, 315, 90);
const PM2 = box('PM2', 0, -315, -90);
const CELL = [LP1, LP2, AL, PM2];

/** The camera's position in plan view for a frame. */
function eye(f: ReturnType<typeof frameCamera>): { x: number; y: number } {
  const a = (f.azimuth * Math.PI) / 180;
  return { x: f.target.x + Math.cos(a) * f.radius * 2.5, y: f.target.y + Math.sin(a) * f.radius * 2.5 };
}

describe('the default camera', () => {
  it('segmentHitsFootprint: a segment through a rotated box hits it, one beside it does not', () => {
    expect(segmentHitsFootprint({ x: 0, y: 0 }, { x: 600, y: -350 }, LP1)).toBe(true);
    expect(segmentHitsFootprint({ x: 0, y: 0 }, { x: 0, y: 100 }, LP1)).toBe(false);
  });

  it('frames the station the hand works at, and no other station stands between it and the hand', () => {
    const hand = { x: 280, y: -160 }; // at LP1
    const f = frameCamera(CELL, hand, null, 550);
    expect(f.station).toBe('LP1');
    const e = eye(f);
    for (const other of [LP2, AL, PM2]) {
      expect(segmentHitsFootprint(e, hand, other), `${other.name} hides the hand`).toBe(false);
      expect(segmentHitsFootprint(e, { x: 0, y: 0 }, other), `${other.name} hides the robot`).toBe(false);
    }
  });

  it("a transfer's station wins over the nearest one; without stations, the robot alone", () => {
    expect(frameCamera(CELL, { x: 280, y: -160 }, 'LP2', 550).station).toBe('LP2');
    expect(frameCamera([], { x: 1, y: 1 }, null, 550)).toMatchObject({ station: null, target: { x: 0, y: 0 } });
  });
});

describe('what a PC without a graphics card is given', () => {
  it('a software renderer draws without antialiasing, at 0.6 pixels per CSS pixel, at most 12 frames a second, with a small hard shadow map', () => {
    const name = 'ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero) (0x0000C0DE)), SwiftShader driver)';
    expect(isSoftwareRenderer(name)).toBe(true);
    expect(renderQuality(name, 2)).toEqual({ tier: 'software', antialias: false, pixelRatio: 0.6, shadowMapSize: 512, softShadows: false, maxFps: 12 });
    expect(isSoftwareRenderer('llvmpipe (LLVM 15.0.6, 256 bits)')).toBe(true);
  });

  it('a graphics card keeps antialiasing and soft shadows', () => {
    const q = renderQuality('ANGLE (NVIDIA, NVIDIA GeForce RTX 3060 Direct3D11 vs_5_0 ps_5_0)', 3);
    expect(q).toMatchObject({ tier: 'gpu', antialias: true, pixelRatio: 2, softShadows: true });
  });
});
