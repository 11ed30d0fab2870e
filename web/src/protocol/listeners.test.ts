import { describe, expect, it, vi } from 'vitest';
import { Listeners } from './listeners';

describe('Listeners', () => {
  it('calls every subscriber, survives a failing one, and forgets the unsubscribed', () => {
    const l = new Listeners<[number]>('test');
    const seen: number[] = [];
    const error = vi.spyOn(console, 'error').mockImplementation(() => {});
    l.add(() => {
      throw new Error('boom');
    });
    const off = l.add((n) => seen.push(n));
    l.emit(1);
    expect(seen).toEqual([1]);
    expect(error).toHaveBeenCalledTimes(1);
    off();
    l.emit(2);
    expect(seen).toEqual([1]);
    // One that unsubscribes itself while called does not stop the emit.
    const late: number[] = [];
    const self = l.add(() => self());
    l.add((n) => late.push(n));
    l.emit(3);
    expect(late).toEqual([3]);
    l.clear();
    l.emit(4);
    expect(late).toEqual([3]);
    error.mockRestore();
  });
});
