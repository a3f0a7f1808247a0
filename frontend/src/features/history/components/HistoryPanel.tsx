import { useCallback, useId, useRef, useState } from 'react';
import { Button } from '@/components/ui/Button';
import { Panel } from '@/components/ui/Panel';
import { ApiError } from '@/lib/api-client';
import { usePolling } from '@/lib/usePolling';
import { useHistoryStore } from '@/stores/historyStore';
import {
  DEFAULT_WINDOW,
  fetchHistory,
  HISTORY_LIMIT,
  HISTORY_WINDOWS,
  localClock,
  type History,
  type HistoryWindow,
  type Sighting,
} from '../api/history';

const PERIOD_MS = 5000;
const UNAVAILABLE_PERIOD_MS = 30_000; // an absent memory server is asked again, less often

type Failure = { kind: 'unavailable' | 'error'; detail: string };

const windowById = (id: string): HistoryWindow =>
  HISTORY_WINDOWS.find((w) => w.id === id) ?? DEFAULT_WINDOW;

/** Sightings in the chosen window (last hour … last 7 days) from the robot's episodic memory;
 *  choosing one marks on the map where the robot was when it saw it (choosing it again, or
 *  Clear, removes the marker). */
export function HistoryPanel() {
  const [windowId, setWindowId] = useState(DEFAULT_WINDOW.id);
  const [history, setHistory] = useState<History | null>(null);
  const [failure, setFailure] = useState<Failure | null>(null);
  const [loading, setLoading] = useState(false);
  const selected = useHistoryStore((s) => s.selected);
  const select = useHistoryStore((s) => s.select);
  const shown = windowById(windowId);
  // The window the panel shows now: an answer for a window the operator has left is dropped.
  const current = useRef(shown.since);
  const selectId = useId();

  const refresh = useCallback(async () => {
    const since = shown.since;
    setLoading(true);
    try {
      const answer = await fetchHistory(since);
      if (current.current !== since) return;
      setHistory(answer);
      setFailure(null);
    } catch (err) {
      if (current.current !== since) return;
      const detail = err instanceof Error ? err.message : String(err);
      setFailure({ kind: err instanceof ApiError && err.status === 503 ? 'unavailable' : 'error', detail });
    } finally {
      if (current.current === since) setLoading(false);
    }
  }, [shown.since]);
  // A new window is fetched at once, and polled from then on.
  usePolling(refresh, failure?.kind === 'unavailable' ? UNAVAILABLE_PERIOD_MS : PERIOD_MS, true, shown.since);

  const chooseWindow = (id: string) => {
    current.current = windowById(id).since;
    setWindowId(id);
    setHistory(null); // never the old window's rows under the new window's name
  };
  const choose = (sighting: Sighting) => select(selected?.id === sighting.id ? null : sighting);

  return (
    <Panel
      label="History"
      title="History"
      className="md:col-span-2 lg:col-span-1"
      actions={
        <div className="flex items-center gap-1.5">
          <label htmlFor={selectId} className="sr-only">
            History window
          </label>
          <select
            id={selectId}
            value={windowId}
            onChange={(e) => chooseWindow(e.target.value)}
            className="rounded-md border border-line bg-surface px-1.5 py-0.5 text-xs text-fg
              focus-visible:outline-2 focus-visible:outline-offset-2 focus-visible:outline-accent"
          >
            {HISTORY_WINDOWS.map((w) => (
              <option key={w.id} value={w.id}>
                {w.label}
              </option>
            ))}
          </select>
          <Button variant="ghost" className="px-2 py-0.5 text-xs" onClick={() => void refresh()} disabled={loading}>
            Refresh
          </Button>
        </div>
      }
    >
      <Body history={history} failure={failure} span={shown.span} selectedId={selected?.id ?? null} onChoose={choose} />
      {selected && (
        <p className="border-t border-line px-3 py-1.5 text-xs text-muted" aria-live="polite">
          {selected.pose
            ? `Map: where the robot was when it saw ${selected.label}.`
            : `No robot position was recorded for ${selected.label}.`}
        </p>
      )}
    </Panel>
  );
}

function Body({
  history,
  failure,
  span,
  selectedId,
  onChoose,
}: {
  history: History | null;
  failure: Failure | null;
  span: string;
  selectedId: string | null;
  onChoose: (sighting: Sighting) => void;
}) {
  if (failure?.kind === 'unavailable') {
    return (
      <p className="px-3 py-2 text-sm text-muted">
        <strong className="font-semibold text-fg">Memory unavailable.</strong> The episodic memory server is not
        connected, so the robot cannot show what it saw.
      </p>
    );
  }
  if (failure) return <p className="px-3 py-2 text-sm text-status-failed">History unavailable: {failure.detail}</p>;
  if (!history) return <p className="px-3 py-2 text-sm text-muted">Loading history…</p>;
  if (history.sightings.length === 0) {
    return <p className="px-3 py-2 text-sm text-muted">Nothing seen {span}.</p>;
  }
  return (
    <>
      <ul aria-label="Recent sightings" className="max-h-64 divide-y divide-line overflow-y-auto lg:max-h-[24vh]">
        {history.sightings.map((s) => (
          <li key={s.id} data-sighting-id={s.id}>
            <SightingRow sighting={s} chosen={s.id === selectedId} onChoose={onChoose} />
          </li>
        ))}
      </ul>
      {history.truncated && (
        <p className="border-t border-line px-3 py-1 text-xs text-muted">
          Showing the newest {HISTORY_LIMIT} sightings {span}.
        </p>
      )}
    </>
  );
}

function SightingRow({
  sighting,
  chosen,
  onChoose,
}: {
  sighting: Sighting;
  chosen: boolean;
  onChoose: (sighting: Sighting) => void;
}) {
  const clock = localClock(sighting.first_seen);
  return (
    <button
      type="button"
      aria-pressed={chosen}
      onClick={() => onChoose(sighting)}
      title={sighting.seen_for ? `seen for ${sighting.seen_for} by ${sighting.skill ?? 'a skill'}` : undefined}
      className={`flex w-full items-baseline justify-between gap-3 px-3 py-1.5 text-left text-sm
        focus-visible:outline-2 focus-visible:-outline-offset-2 focus-visible:outline-accent
        ${chosen ? 'bg-raised' : 'hover:bg-raised'}`}
    >
      <span className="min-w-0">
        <span className={`block truncate font-medium ${chosen ? 'text-accent' : ''}`}>{sighting.label}</span>
        <span className="block truncate text-xs text-muted">{sighting.place ?? 'no named place'}</span>
      </span>
      <span className="shrink-0 text-right text-xs tabular-nums">
        <time dateTime={sighting.first_seen} className="block">
          {clock}
        </time>
        {sighting.ago && <span className="block text-muted">{sighting.ago}</span>}
      </span>
    </button>
  );
}
