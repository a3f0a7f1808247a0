import { useState } from 'react';
import type { ActivityLine } from '@/stores/missionStore';

const KIND_LABEL: Record<ActivityLine['kind'], string> = {
  tool_call: 'tool',
  task_event: 'task',
  reaction: 'reaction',
  say: 'says',
  user_turn: 'you',
};

function clock(ts: number): string {
  return new Date(ts * 1000).toLocaleTimeString([], { hour12: false });
}

/** The collapsible mission_event feed under the pipeline (newest last, bounded by the store). */
export function ActivityLog({ lines }: { lines: ActivityLine[] }) {
  const [open, setOpen] = useState(true);
  return (
    <section aria-label="Activity" className="border-t border-line px-3 py-2">
      <button
        type="button"
        aria-expanded={open}
        onClick={() => setOpen(!open)}
        className="text-xs font-semibold text-muted hover:text-fg"
      >
        {open ? '▾' : '▸'} Activity ({lines.length})
      </button>
      {open && (
        <ol className="mt-1 max-h-48 overflow-y-auto font-mono text-xs">
          {lines.slice(-100).map((line) => (
            <li key={line.key} className="flex gap-2 py-0.5">
              <span className="text-muted">{clock(line.ts)}</span>
              <span className="w-14 shrink-0 text-muted">{KIND_LABEL[line.kind]}</span>
              <span className="break-words">{line.text}</span>
            </li>
          ))}
        </ol>
      )}
    </section>
  );
}
