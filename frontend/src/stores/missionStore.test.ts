import { beforeEach, describe, expect, it } from 'vitest';
import { fiveStates } from '@/testing/fixtures';
import { ACTIVITY_LIMIT, useMissionStore } from './missionStore';

const store = () => useMissionStore.getState();

describe('missionStore', () => {
  beforeEach(() => store().clear());

  it('replaces the plan with each snapshot instead of patching it', () => {
    store().applySnapshot(fiveStates);
    store().applySnapshot({ mission_id: 'm-abc123', state: 'running', steps: [{ id: 's7', title: 'New plan' }] });
    expect(store().mission?.steps.map((s) => [s.id, s.status, s.isNew])).toEqual([['s7', 'pending', true]]);
  });

  it('keeps the instruction and start time across snapshots of the same mission', () => {
    store().started({ mission_id: 'm-abc123', instruction: 'Fetch it', started_at: 42 });
    store().applySnapshot({ ...fiveStates, started_at: undefined });
    expect(store().mission).toMatchObject({ instruction: 'Fetch it', startedAt: 42, state: 'running' });
  });

  it('a snapshot of another mission starts afresh', () => {
    store().started({ mission_id: 'm-old', instruction: 'Old' });
    store().addEvent({ mission_id: 'm-old', kind: 'say', text: 'x', ts: 1 });
    store().applySnapshot(fiveStates);
    expect(store().mission).toMatchObject({ id: 'm-abc123', instruction: '' });
    expect(store().activity).toEqual([]);
  });

  it('appends events in order and keeps the log bounded', () => {
    store().applySnapshot(fiveStates);
    for (let i = 0; i < ACTIVITY_LIMIT + 25; i++) {
      store().addEvent({ mission_id: 'm-abc123', kind: 'task_event', text: `e${i}`, ts: i });
    }
    const lines = store().activity;
    expect(lines).toHaveLength(ACTIVITY_LIMIT);
    expect(lines[0]!.text).toBe('e25');
    expect(lines.at(-1)!.text).toBe(`e${ACTIVITY_LIMIT + 24}`);
    expect(new Set(lines.map((l) => l.key)).size).toBe(ACTIVITY_LIMIT);
  });

  it('ignores events of another mission', () => {
    store().applySnapshot(fiveStates);
    store().addEvent({ mission_id: 'm-other', kind: 'say', text: 'nope', ts: 1 });
    expect(store().activity).toEqual([]);
  });

  it('rehydrates a mission from the REST snapshot and its trace lines', () => {
    store().rehydrate({ ...fiveStates, instruction: 'Fetch the package', teaching: true }, [
      { kind: 'task_event', text: 'nav-1 task_failed', ts: 5 },
    ]);
    const mission = store().mission!;
    expect(mission).toMatchObject({ id: 'm-abc123', instruction: 'Fetch the package', teaching: true, state: 'running' });
    expect(mission.steps).toHaveLength(5);
    expect(mission.steps.every((s) => !s.isNew)).toBe(true);
    expect(store().activity.map((l) => l.text)).toEqual(['nav-1 task_failed']);
  });

  it('a late REST rehydrate keeps newer live steps and lines but adds the instruction', () => {
    store().applySnapshot({ ...fiveStates, steps: fiveStates.steps!.slice(0, 2) });
    store().addEvent({ mission_id: 'm-abc123', kind: 'say', text: 'live line', ts: 2 });
    store().rehydrate({ ...fiveStates, steps: fiveStates.steps!.slice(0, 1), instruction: 'Fetch it' }, [
      { kind: 'task_event', text: 'old trace line', ts: 1 },
    ]);
    expect(store().mission?.instruction).toBe('Fetch it');
    expect(store().mission?.steps.map((s) => s.id)).toEqual(['s1', 's1b']);
    expect(store().activity.map((l) => l.text)).toEqual(['live line']);
  });

  it('mission_finished sets the outcome of the current mission only', () => {
    store().applySnapshot(fiveStates);
    store().finished({ mission_id: 'm-other', outcome: 'failed', summary: '' });
    expect(store().mission?.state).toBe('running');
    store().finished({ mission_id: 'm-abc123', outcome: 'succeeded', summary: 'ok' });
    expect(store().mission?.state).toBe('succeeded');
  });
});
