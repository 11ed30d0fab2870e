import { describe, expect, it } from 'vitest';
import { WatchList, watchNameOk } from './watch';

describe('WatchList', () => {
  it('takes variables and elements, each once', () => {
    const w = new WatchList();
    expect(w.add(' COUNT ')).toBe(true);
    expect(w.add('count')).toBe(false);
    expect(w.add('SLOTS[3]')).toBe(true);
    expect(w.add('name$')).toBe(true);
    expect(w.add('3X')).toBe(false);
    expect(w.add('A B')).toBe(false);
    expect(w.names()).toEqual(['COUNT', 'SLOTS[3]', 'name$']);
    expect(watchNameOk('M[1,2]')).toBe(false);
  });

  it('reads four names a request and keeps the values', () => {
    const w = new WatchList(['A', 'B', 'C', 'D', 'E']);
    expect(w.requests()).toEqual(['VARS A B C D', 'VARS E']);
    w.apply([
      { name: 'a', known: true, type: 'number', value: '1' },
      { name: 'E', known: false, why: '' },
      { name: 'Z', known: true, type: 'number', value: '9' },
    ]);
    expect(w.value('A')).toEqual({ kind: 'value', type: 'number', value: '1' });
    expect(w.value('E')).toEqual({ kind: 'unknown', why: '' });
    expect(w.value('B')).toEqual({ kind: 'none' });
    w.clearValues();
    expect(w.value('A')).toEqual({ kind: 'none' });
    w.remove('A');
    expect(w.requests()).toEqual(['VARS B C D E']);
  });
});
