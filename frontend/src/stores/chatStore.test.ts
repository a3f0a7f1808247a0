import { beforeEach, describe, expect, it } from 'vitest';
import { useChatStore } from './chatStore';

const store = () => useChatStore.getState();

describe('chatStore', () => {
  beforeEach(() => useChatStore.setState({ feed: [], streaming: {}, announcement: '', draft: '' }));

  it('streams deltas until the complete chat_message replaces them', () => {
    store().delta('t1', 'Hel');
    store().delta('t1', 'lo');
    expect(store().streaming).toEqual({ t1: 'Hello' });
    store().message('t1', 'assistant', 'Hello there');
    expect(store().streaming).toEqual({});
    expect(store().feed.at(-1)).toMatchObject({ kind: 'message', role: 'assistant', text: 'Hello there' });
    expect(store().announcement).toBe('Hello there');
  });

  it('shows errors inline and stops the stream of that turn', () => {
    store().delta('t2', 'Par');
    store().error('t2', 'Sorry, I can’t answer right now');
    expect(store().streaming).toEqual({});
    expect(store().feed.at(-1)).toMatchObject({ kind: 'error', text: 'Sorry, I can’t answer right now' });
  });

  it('puts history before live lines', () => {
    store().message('t3', 'user', 'live');
    store().load([{ kind: 'message', key: 'h0', turnId: 'old', role: 'user', text: 'from history' }]);
    expect(store().feed.map((f) => (f.kind === 'message' ? f.text : ''))).toEqual(['from history', 'live']);
  });
});
