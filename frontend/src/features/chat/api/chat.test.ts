import { afterEach, describe, expect, it, vi } from 'vitest';
import { fetchHistory } from './chat';

afterEach(() => vi.unstubAllGlobals());

describe('fetchHistory', () => {
  it('keeps a finished mission’s human title after a reload (issue 39)', async () => {
    const lines = [
      { event: 'chat_message', turn_id: 't1', role: 'user', text: 'go to the kitchen' },
      { event: 'mission_finished', mission_id: 'm-af2fa4', outcome: 'succeeded', summary: 'I’m in the kitchen.', instruction: 'go to the kitchen' },
    ];
    vi.stubGlobal('fetch', vi.fn(async () => new Response(JSON.stringify({ lines }), { status: 200 })));
    const feed = await fetchHistory();
    const card = feed.find((item) => item.kind === 'summary');
    expect(card).toMatchObject({ kind: 'summary', missionId: 'm-af2fa4', instruction: 'go to the kitchen' });
  });
});
