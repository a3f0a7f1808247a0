import { create } from 'zustand';
import type { Step } from '@/stores/missionStore';

export type FeedItem =
  | { kind: 'message'; key: string; turnId: string; role: 'user' | 'assistant'; text: string }
  | { kind: 'error'; key: string; turnId: string; text: string }
  | {
      kind: 'summary';
      key: string;
      missionId: string;
      instruction: string;
      outcome: string;
      summary: string;
      steps: Step[];
      /** Planner tokens and cost of the mission (absent when the brain reported none). */
      usage?: MissionUsage;
    };

export interface MissionUsage {
  input_tokens?: number | null;
  output_tokens?: number | null;
  cost_usd?: number | null;
}

/** The feed keeps this many items; older ones are still in the brain's history. */
export const FEED_LIMIT = 200;

interface ChatStore {
  feed: FeedItem[];
  /** Streaming replies being typed, by turn id. */
  streaming: Record<string, string>;
  /** Latest assistant line, for the ARIA live region. */
  announcement: string;
  draft: string;
  counter: number;
  delta: (turnId: string, text: string) => void;
  message: (turnId: string, role: 'user' | 'assistant', text: string) => void;
  error: (turnId: string, text: string) => void;
  summary: (item: Omit<Extract<FeedItem, { kind: 'summary' }>, 'kind' | 'key'>) => void;
  load: (items: FeedItem[]) => void;
  setDraft: (draft: string) => void;
}

function bounded(feed: FeedItem[], item: FeedItem): FeedItem[] {
  return [...feed.slice(Math.max(0, feed.length - FEED_LIMIT + 1)), item];
}

function withoutStream(streaming: Record<string, string>, turnId: string): Record<string, string> {
  if (!(turnId in streaming)) return streaming;
  return Object.fromEntries(Object.entries(streaming).filter(([id]) => id !== turnId));
}

export const useChatStore = create<ChatStore>()((set) => ({
  feed: [],
  streaming: {},
  announcement: '',
  draft: '',
  counter: 0,
  delta: (turnId, text) =>
    set((s) => ({ streaming: { ...s.streaming, [turnId]: (s.streaming[turnId] ?? '') + text } })),
  message: (turnId, role, text) =>
    set((s) => ({
      feed: bounded(s.feed, { kind: 'message', key: `m${s.counter}`, turnId, role, text }),
      counter: s.counter + 1,
      streaming: role === 'assistant' ? withoutStream(s.streaming, turnId) : s.streaming,
      announcement: role === 'assistant' ? text : s.announcement,
    })),
  error: (turnId, text) =>
    set((s) => ({
      feed: bounded(s.feed, { kind: 'error', key: `e${s.counter}`, turnId, text }),
      counter: s.counter + 1,
      streaming: withoutStream(s.streaming, turnId),
      announcement: text,
    })),
  summary: (item) =>
    set((s) => ({
      feed: bounded(
        s.feed.filter((f) => !(f.kind === 'summary' && f.missionId === item.missionId)),
        { kind: 'summary', key: `s${s.counter}`, ...item },
      ),
      counter: s.counter + 1,
      announcement: item.summary,
    })),
  load: (items) => set((s) => ({ feed: [...items, ...s.feed].slice(-FEED_LIMIT) })),
  setDraft: (draft) => set({ draft }),
}));
