import { useEffect, useRef } from 'react';
import { useChatStore, type FeedItem } from '@/stores/chatStore';
import { SummaryCard } from './SummaryCard';

function Bubble({ role, text, streaming = false }: { role: 'user' | 'assistant'; text: string; streaming?: boolean }) {
  const mine = role === 'user';
  return (
    <div className={`flex ${mine ? 'justify-end' : 'justify-start'}`}>
      <p
        className={`max-w-[85%] rounded-2xl px-3 py-1.5 text-sm whitespace-pre-wrap ${
          mine ? 'bg-accent text-accent-fg' : 'bg-raised text-fg'
        }`}
      >
        <span className="sr-only">{mine ? 'You: ' : 'Robot: '}</span>
        {text}
        {streaming && <span aria-hidden="true" className="animate-pulse"> ▍</span>}
      </p>
    </div>
  );
}

function Item({ item }: { item: FeedItem }) {
  if (item.kind === 'message') return <Bubble role={item.role} text={item.text} />;
  if (item.kind === 'error')
    return (
      <p role="alert" className="rounded-md border border-status-failed px-3 py-1.5 text-sm text-status-failed">
        {item.text}
      </p>
    );
  return <SummaryCard item={item} />;
}

/** The conversation feed; streamed replies grow in place until their chat_message lands. */
export function Conversation() {
  const feed = useChatStore((s) => s.feed);
  const streaming = useChatStore((s) => s.streaming);
  const end = useRef<HTMLDivElement>(null);
  useEffect(() => {
    end.current?.scrollIntoView?.({ block: 'end' });
  }, [feed, streaming]);
  return (
    <div role="log" aria-label="Conversation" className="flex flex-1 flex-col gap-2 overflow-y-auto p-3">
      {feed.length === 0 && <p className="text-sm text-muted">Say hello, or give the robot a task.</p>}
      {feed.map((item) => (
        <Item key={item.key} item={item} />
      ))}
      {Object.entries(streaming).map(([turnId, text]) => (
        <Bubble key={`stream-${turnId}`} role="assistant" text={text} streaming />
      ))}
      <div ref={end} />
    </div>
  );
}

/** Screen readers hear the robot's replies (polite live region). */
export function LiveAnnouncer() {
  const announcement = useChatStore((s) => s.announcement);
  return (
    <div aria-live="polite" aria-atomic="true" className="sr-only">
      {announcement}
    </div>
  );
}
