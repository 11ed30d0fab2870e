// The 3D view's materials, shared by the robot (rebuilt whenever the robot changes) and the
// wafers in the stations, and the tint each controller state gives the robot's moving parts.

import * as THREE from 'three';
import type { RobotState } from '../protocol/bus';

interface Tint {
  color: THREE.Color;
  amount: number;
  emissive: THREE.Color;
}

const TINTS: Record<RobotState, Tint> = {
  IDLE: { color: new THREE.Color('#ffffff'), amount: 0, emissive: new THREE.Color('#000000') },
  MOVING: { color: new THREE.Color('#ffffff'), amount: 0, emissive: new THREE.Color('#000000') },
  STOPPING: { color: new THREE.Color('#f0a020'), amount: 0.35, emissive: new THREE.Color('#1a1000') },
  // Held on its path: blue, apart from STOPPING's amber, so a kept motion reads as paused.
  HELD: { color: new THREE.Color('#4a9ae8'), amount: 0.35, emissive: new THREE.Color('#0a1420') },
  ERROR: { color: new THREE.Color('#ff3020'), amount: 0.55, emissive: new THREE.Color('#300600') },
  ESTOP: { color: new THREE.Color('#ff2010'), amount: 0.7, emissive: new THREE.Color('#4a0800') },
};

const JOINT_COLOR: Record<RobotState, string> = {
  IDLE: '#2a2f35',
  MOVING: '#2fa84f',
  STOPPING: '#c88a1a',
  HELD: '#3f8fd8',
  ERROR: '#b8281e',
  ESTOP: '#d01e14',
};

/**
 * The face of an uncertain wafer: diagonal amber hatching with a large `?` in the middle (the
 * disc's caps map the texture's centre to the wafer's centre). Null outside a browser.
 */
function uncertainTexture(): THREE.Texture | null {
  const size = 256;
  // The page's canvas, or in the render worker an OffscreenCanvas.
  let c: HTMLCanvasElement | OffscreenCanvas;
  if (typeof document !== 'undefined') {
    c = document.createElement('canvas');
    c.width = size;
    c.height = size;
  } else if (typeof OffscreenCanvas !== 'undefined') c = new OffscreenCanvas(size, size);
  else return null;
  const g = c.getContext('2d') as CanvasRenderingContext2D | OffscreenCanvasRenderingContext2D | null;
  if (!g) return null;
  g.fillStyle = '#ffffff';
  g.fillRect(0, 0, size, size);
  g.strokeStyle = '#8a5a00';
  g.lineWidth = 10;
  for (let k = -size; k < 2 * size; k += 36) {
    g.beginPath();
    g.moveTo(k, 0);
    g.lineTo(k + size, size);
    g.stroke();
  }
  g.fillStyle = '#2a1a00';
  g.font = `bold ${Math.round(size * 0.6)}px sans-serif`;
  g.textAlign = 'center';
  g.textBaseline = 'middle';
  g.fillText('?', size / 2, size / 2 + size * 0.03);
  const t = new THREE.CanvasTexture(c as HTMLCanvasElement);
  t.colorSpace = THREE.SRGBColorSpace;
  return t;
}

/** A material whose colour follows the state, with its normal colour. */
class TintedMaterial {
  readonly base: THREE.Color;
  constructor(readonly mat: THREE.MeshStandardMaterial) {
    this.base = mat.color.clone();
  }
  apply(t: Tint): void {
    this.mat.color.copy(this.base).lerp(t.color, t.amount);
    this.mat.emissive.copy(t.emissive);
  }
}

/** Every material of the view but the floor's and the stations' (which are made per object). */
export class Materials {
  readonly link = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#c3c9d1', metalness: 0.15, roughness: 0.5 }),
  );
  readonly base = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#3b4149', metalness: 0.1, roughness: 0.7 }),
  );
  readonly column = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#9aa1a9', metalness: 0.25, roughness: 0.35 }),
  );
  readonly hand = new TintedMaterial(
    new THREE.MeshStandardMaterial({ color: '#e4e0d6', metalness: 0.05, roughness: 0.6 }),
  );
  readonly joint = new THREE.MeshStandardMaterial({ color: JOINT_COLOR.IDLE, metalness: 0.3, roughness: 0.5 });
  readonly wafer = new THREE.MeshStandardMaterial({
    color: '#8597c4',
    metalness: 0.6,
    roughness: 0.2,
    transparent: true,
    opacity: 0.5,
    depthWrite: false,
    side: THREE.DoubleSide,
  });
  readonly trim = new THREE.MeshStandardMaterial({ color: '#e0a526', metalness: 0.1, roughness: 0.6 });
  // Faulty slots: a double wafer red, a cross-slotted one orange (as in the Wafers panel).
  readonly double = new THREE.MeshStandardMaterial({ color: '#e0352b', metalness: 0.3, roughness: 0.4, emissive: '#3a0500' });
  readonly cross = new THREE.MeshStandardMaterial({ color: '#f08a1c', metalness: 0.3, roughness: 0.4, emissive: '#2e1600' });
  // An uncertain wafer (perhaps there, perhaps not, after an interrupted transfer): amber,
  // fainter than a wafer, hatched, with a `?` on its face (as in the Wafers panel).
  readonly uncertain = new THREE.MeshStandardMaterial({
    color: '#ffb020',
    metalness: 0.1,
    roughness: 0.6,
    emissive: '#3a2400',
    transparent: true,
    opacity: 0.55,
    depthWrite: false,
    side: THREE.DoubleSide,
    map: uncertainTexture(),
  });
  // The base housing keeps its colour: the moving parts show the state.
  private readonly tinted = [this.link, this.column, this.hand];

  /** Colour the moving parts and the joint caps for state `s`. */
  tint(s: RobotState): void {
    const t = TINTS[s];
    for (const m of this.tinted) m.apply(t);
    this.joint.color.set(JOINT_COLOR[s]);
  }
}
