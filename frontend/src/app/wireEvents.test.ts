import { afterEach, beforeEach, describe, expect, it, vi } from 'vitest';
import type { RobotSocket } from '@/lib/socket';
import { useChatStore } from '@/stores/chatStore';
import { useConnectionStore } from '@/stores/connectionStore';
import { useMissionStore } from '@/stores/missionStore';
import { useSettingsStore, type UiConfig } from '@/stores/settingsStore';
import { fiveStates } from '@/testing/fixtures';
import type { ServerEvents } from '@/types/events';
import { wireEvents } from './wireEvents';

type Handler = (payload: never) => void;

const uiConfig: UiConfig = {
  deployment: 'dev',
  llm: 'rules',
  planner: 'rules',
  speech_input: false,
  speech_input_reason: null,
  speech_output_browser: false,
  camera: false,
};

/** Records handlers the way socket.io-client would, and lets the test deliver events. */
function fakeSocket() {
  const handlers = new Map<string, Handler>();
  const managerHandlers = new Map<string, Handler>();
  const socket = {
    on: (event: string, fn: Handler) => handlers.set(event, fn),
    io: { on: (event: string, fn: Handler) => managerHandlers.set(event, fn), removeAllListeners: vi.fn() },
    connect: vi.fn(),
    disconnect: vi.fn(),
    removeAllListeners: vi.fn(),
  };
  const deliver = <E extends keyof ServerEvents>(event: E, payload: ServerEvents[E]) =>
    (handlers.get(event) as ((p: ServerEvents[E]) => void) | undefined)?.(payload);
  const raw = (event: string, payload?: unknown) => (handlers.get(event) ?? managerHandlers.get(event))?.(payload as never);
  return { socket: socket as unknown as RobotSocket, deliver, raw };
}

describe('wireEvents', () => {
  beforeEach(() => {
    vi.useFakeTimers();
    useMissionStore.getState().clear();
    useChatStore.setState({ feed: [], streaming: {} });
  });
  afterEach(() => vi.useRealTimers());

  it('renders only the newest of a burst of snapshots, and never loses the final one', () => {
    const { socket, deliver } = fakeSocket();
    wireEvents(socket, () => undefined);
    for (let i = 0; i < 50; i++) {
      deliver('mission_plan', { ...fiveStates, steps: [{ id: 's1', title: `step ${i}` }] });
    }
    expect(useMissionStore.getState().mission).toBeNull(); // nothing rendered mid-burst
    vi.runAllTimers();
    expect(useMissionStore.getState().mission?.steps[0]?.title).toBe('step 49');
  });

  it('flushes the pending snapshot before mission_finished builds the summary card', () => {
    const { socket, deliver } = fakeSocket();
    wireEvents(socket, () => undefined);
    deliver('mission_started', { mission_id: 'm-abc123', instruction: 'Fetch it' });
    deliver('mission_plan', { ...fiveStates, state: 'succeeded' });
    deliver('mission_finished', { mission_id: 'm-abc123', outcome: 'succeeded', summary: 'Done.' });
    const card = useChatStore.getState().feed.at(-1);
    expect(card).toMatchObject({ kind: 'summary', instruction: 'Fetch it', outcome: 'succeeded' });
    expect(card?.kind === 'summary' && card.steps.map((s) => s.status)).toEqual([
      'failed',
      'succeeded',
      'running',
      'pending',
      'skipped',
    ]);
  });

  it('tracks the connection and rehydrates after a reconnect', () => {
    const { socket, raw } = fakeSocket();
    const rehydrate = vi.fn();
    wireEvents(socket, rehydrate);
    raw('connect');
    expect(rehydrate).not.toHaveBeenCalled();
    raw('disconnect');
    raw('reconnect_attempt', 3);
    expect(useConnectionStore.getState()).toMatchObject({ state: 'reconnecting', attempts: 3 });
    raw('connect');
    expect(useConnectionStore.getState()).toMatchObject({ state: 'connected', attempts: 0 });
    expect(rehydrate).toHaveBeenCalledOnce();
  });

  it('speaks the robot sentences and stops at once on speech_interrupted (barge-in)', () => {
    const synthesis = { speak: vi.fn(), cancel: vi.fn() };
    vi.stubGlobal('speechSynthesis', synthesis);
    vi.stubGlobal('SpeechSynthesisUtterance', class {
      constructor(readonly text: string) {}
    });
    useSettingsStore.setState({ muted: false, config: { ...uiConfig, speech_output_browser: true } });
    try {
      const { socket, deliver } = fakeSocket();
      wireEvents(socket, () => undefined);
      deliver('speak', { text: 'Driving to the kitchen.', utterance_id: 'u1' });
      expect(synthesis.speak).toHaveBeenCalledTimes(1);
      deliver('speech_interrupted', {});
      expect(synthesis.cancel).toHaveBeenCalledTimes(1);
    } finally {
      vi.unstubAllGlobals();
    }
  });
});

