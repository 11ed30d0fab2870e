import { describe, expect, it } from 'vitest';
import { HOLD_TITLE, RESUME_TITLE } from './control-panel';

describe('the HOLD and RESUME buttons', () => {
  it('have the titles the operator reads', () => {
    expect(RESUME_TITLE).toBe('RESUME: continue the held motion on its path');
    expect(HOLD_TITLE).toBe('HOLD: brake on the path and keep the motion (RESUME continues it)');
  });
});
