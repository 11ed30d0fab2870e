import { describe, expect, it } from 'vitest';
import type { Bus, FinalReply, FirstReply } from './bus';
import { CommandLog, Commander } from './commander';
import { ControllerModel } from './controller-model';

type Reply = { first: FirstReply; final: Promise<FinalReply> | null } | Error;

/** A connected bus that answers each request with the reply `answer` gives for it. */
function fakeBus(answer: (line: string) => Reply) {
  const asked: string[] = [];
  const bus: Bus = {
    connected: () => true,
    onConnection: () => () => undefined,
    robot: () => null,
    onRobot: () => () => undefined,
    onSample: () => () => undefined,
    onEvent: () => () => undefined,
    request: (line) => {
      asked.push(line);
      const r = answer(line);
      return r instanceof Error ? Promise.reject(r) : Promise.resolve({ ...r, events: [] });
    },
    upload: () => new Promise(() => undefined),
  };
  return { bus, asked };
}

const ack = (id: number, fields: Record<string, string> = {}, line = `ACK ${id}`): FirstReply => ({ kind: 'ACK', id, fields, line });
const nak = (id: number, code: number, text: string): FirstReply => ({ kind: 'NAK', id, code, text, line: `NAK ${id} ${code} ${text}` });

const flush = async (): Promise<void> => {
  for (let i = 0; i < 10; i++) await Promise.resolve();
};

function texts(log: CommandLog): string[] {
  return log.entries().map((e) => `${e.kind} ${e.text}`);
}

describe('Commander', () => {
  it('logs a request, its ACK and, for a motion, its INF', async () => {
    let finish: (f: FinalReply) => void = () => undefined;
    const { bus } = fakeBus(() => ({ first: ack(1), final: new Promise<FinalReply>((r) => (finish = r)) }));
    const cmd = new Commander(bus, new ControllerModel(bus));
    const sent = await cmd.send('HOME');
    expect(sent?.first.kind).toBe('ACK');
    expect(texts(cmd.log)).toEqual(['out > HOME', 'ack ACK HOME (started)']);
    finish({ kind: 'INF', id: 1, fields: {}, line: 'INF 1' });
    await flush();
    expect(texts(cmd.log)).toEqual(['out > HOME', 'ack ACK HOME (started)', 'inf INF HOME finished']);
  });

  it("logs a NAK with its code, an ABS with its code, and the INF's words after the id", async () => {
    const { bus } = fakeBus((line) =>
      line.startsWith('MOVP')
        ? { first: nak(2, 111, 'out of reach'), final: null }
        : line.startsWith('GET')
          ? { first: ack(3), final: Promise.resolve<FinalReply>({ kind: 'INF', id: 3, fields: {}, line: 'INF 3 W3' }) }
          : { first: ack(4), final: Promise.resolve<FinalReply>({ kind: 'ABS', id: 4, code: 201, text: 'emergency stop', line: 'ABS 4 201 emergency stop' }) },
    );
    const cmd = new Commander(bus, new ControllerModel(bus));
    await cmd.send('MOVP 1000 0 0 0');
    await cmd.send('GET LP1 3');
    await flush();
    await cmd.send('MOVJ 1 2 3 4');
    await flush();
    expect(texts(cmd.log)).toEqual([
      'out > MOVP 1000 0 0 0',
      'nak NAK MOVP: 111 out of reach',
      'out > GET LP1 3',
      'ack ACK GET (started)',
      'inf INF GET finished: W3',
      'out > MOVJ 1 2 3 4',
      'ack ACK MOVJ (started)',
      // A stop someone asked for is logged as a stop, not as a fault.
      'stop ABS MOVJ: 201 emergency stop',
    ]);
  });

  it('logs a fault that ends a motion as an ABS, and tells its listeners every reply', async () => {
    const { bus } = fakeBus(() => ({
      first: ack(5),
      final: Promise.resolve<FinalReply>({ kind: 'ABS', id: 5, code: 203, text: 'following error', line: 'ABS 5 203 following error' }),
    }));
    const cmd = new Commander(bus, new ControllerModel(bus));
    const heard: string[] = [];
    cmd.onReply((o) => heard.push(`${o.kind} ${o.request}`));
    await cmd.send('MOVJ 1 2 3 4');
    await flush();
    expect(texts(cmd.log).at(-1)).toBe('abs ABS MOVJ: 203 following error');
    expect(heard).toEqual(['first MOVJ 1 2 3 4', 'final MOVJ 1 2 3 4']);
  });

  it('hands the request to the bus before it logs anything (the E-STOP leaves first)', async () => {
    let loggedBefore = -1;
    let cmd: Commander | null = null;
    const { bus } = fakeBus(() => {
      loggedBefore = cmd?.log.entries().length ?? -1;
      return { first: ack(1), final: null };
    });
    cmd = new Commander(bus, new ControllerModel(bus));
    await cmd.send('ESTOP');
    expect(loggedBefore).toBe(0);
    expect(texts(cmd.log)).toEqual(['out > ESTOP', 'ack ACK ESTOP']);
  });

  it('logs a request that could not be sent, and resolves null', async () => {
    const { bus } = fakeBus(() => new Error('not connected'));
    const cmd = new Commander(bus, new ControllerModel(bus));
    expect(await cmd.send('STOP')).toBeNull();
    expect(texts(cmd.log)).toEqual(['out > STOP', 'nak STOP: not connected']);
  });

  it('tells the model the reply (CONTROL names this page) and asks STATUS and IO after an OUT', async () => {
    const { bus, asked } = fakeBus((line) =>
      line === 'CONTROL' ? { first: ack(1, { owner: 'gui0' }), final: null } : { first: ack(2), final: null },
    );
    const model = new ControllerModel(bus);
    const cmd = new Commander(bus, model);
    await cmd.send('CONTROL');
    expect(model.holdsControl()).toBe(true);
    expect(texts(cmd.log)).toEqual(['out > CONTROL', 'ack ACK CONTROL owner=gui0']);
    await cmd.send('OUT 3 1');
    expect(asked).toEqual(['CONTROL', 'OUT 3 1', 'STATUS', 'IO']);
  });
});

describe('CommandLog', () => {
  it('keeps the newest entries and tells its listeners of each one', () => {
    const log = new CommandLog();
    const heard: string[] = [];
    const stop = log.onAdd((e) => heard.push(e.text));
    for (let i = 0; i < CommandLog.MAX_ENTRIES + 5; i++) log.add('info', `line ${i}`);
    stop();
    log.add('info', 'unheard');
    const entries = log.entries();
    expect(entries).toHaveLength(CommandLog.MAX_ENTRIES);
    expect(entries[0]?.text).toBe('line 6');
    expect(entries[entries.length - 1]?.text).toBe('unheard');
    expect(heard).toHaveLength(CommandLog.MAX_ENTRIES + 5);
  });
});
