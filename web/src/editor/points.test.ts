import { describe, expect, it } from 'vitest';
import { PointStore, pointDeleteRequest, pointHereRequest, pointNameOk, pointSetRequest, readNumbers } from './points';

describe('PointStore', () => {
  it('is filled by POINTS and kept by EVT POINT of its program only', () => {
    const s = new PointStore();
    s.replaceAll('demo', [
      { program: 'demo', name: 'SAFE', value: { kind: 'pose', x: 250, y: 0, z: 10, yaw: 0 } },
      { program: 'demo', name: 'PARK', value: { kind: 'joints', joints: [-75, 150, -75, 0] } },
    ]);
    expect(s.list().map((p) => p.name)).toEqual(['PARK', 'SAFE']);
    expect(s.apply({ program: 'other', name: 'X', value: { kind: 'pose', x: 1, y: 2, z: 3, yaw: 4 } })).toBe(false);
    expect(s.apply({ program: 'demo', name: 'safe', value: { kind: 'pose', x: 260, y: 40, z: 10, yaw: 0 } })).toBe(true);
    // The name keeps its first spelling.
    expect(s.get('SAFE')).toEqual({ name: 'SAFE', value: { kind: 'pose', x: 260, y: 40, z: 10, yaw: 0 } });
    expect(s.apply({ program: 'demo', name: 'PARK', value: null })).toBe(true);
    expect(s.list().map((p) => p.name)).toEqual(['SAFE']);
    s.clear('next');
    expect(s.list()).toEqual([]);
    expect(s.program).toBe('next');
  });

  it("writes the points file that wrc-lang reads", () => {
    const s = new PointStore();
    expect(s.toToml()).toBe('');
    s.replaceAll('demo', [
      { program: 'demo', name: 'SAFE', value: { kind: 'pose', x: 250, y: -0.5, z: 10, yaw: 1e-7 } },
      { program: 'demo', name: 'PARK', value: { kind: 'joints', joints: [-75, 150, -75, 0] } },
    ]);
    expect(s.toToml()).toBe(
      '[points]\nPARK = { joints = [-75.0, 150.0, -75.0, 0.0] }\nSAFE = { x = 250.0, y = -0.5, z = 10.0, yaw = 1e-7 }\n',
    );
  });
});

describe('POINT requests', () => {
  it('sets, teaches and deletes', () => {
    expect(pointSetRequest('demo', 'SAFE', { kind: 'pose', x: 250, y: 0.1234567, z: -10, yaw: 1e-7 })).toBe(
      'POINT demo SAFE 250 0.123457 -10 0',
    );
    expect(pointSetRequest('demo', 'PARK', { kind: 'joints', joints: [-75, 150, -75, 0] })).toBe('POINT demo PARK JOINTS -75 150 -75 0');
    expect(pointHereRequest('demo', 'SAFE')).toBe('POINT demo SAFE HERE');
    expect(pointDeleteRequest('demo', 'SAFE')).toBe('POINT demo SAFE DELETE');
  });

  it('checks names and typed numbers', () => {
    expect(pointNameOk('P_1')).toBe(true);
    expect(pointNameOk('1P')).toBe(false);
    expect(pointNameOk('x'.repeat(33))).toBe(false);
    expect(readNumbers([{ label: 'x', text: ' 2.5 ' }, { label: 'y', text: '-1' }])).toEqual([2.5, -1]);
    expect(readNumbers([{ label: 'x', text: '' }])).toBe('x must be a number');
    expect(readNumbers([{ label: 'yaw', text: 'abc' }])).toBe('yaw must be a number');
  });
});
