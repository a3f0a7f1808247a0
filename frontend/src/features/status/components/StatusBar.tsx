import { useCallback, useState } from 'react';
import { usePolling } from '@/lib/usePolling';
import { useConnectionStore } from '@/stores/connectionStore';
import { useSafetyStore } from '@/stores/safetyStore';
import { useSettingsStore } from '@/stores/settingsStore';
import { HoldingChip } from '@/features/hands/components/HoldingChip';
import { fetchReadiness, type Readiness } from '../api/status';

const SERVER_TONE = {
  connected: 'bg-status-succeeded',
  connecting: 'bg-status-skipped',
  disconnected: 'bg-status-failed',
} as const;

export function StatusBar() {
  const socket = useConnectionStore();
  const latch = useSafetyStore((s) => s.latch);
  const recognizer = useSettingsStore((s) => (s.config ? (s.config.speech_input_name ?? 'off') : null));
  const [ready, setReady] = useState<Readiness | null>(null);
  const [unreachable, setUnreachable] = useState(false);
  const tick = useCallback(async () => {
    try {
      setReady(await fetchReadiness());
      setUnreachable(false);
    } catch {
      setUnreachable(true);
    }
  }, []);
  usePolling(tick, 5000);

  const socketText =
    socket.state === 'connected'
      ? 'connected'
      : socket.state === 'reconnecting'
        ? `reconnecting (attempt ${socket.attempts})`
        : socket.state;
  return (
    <footer className="border-t border-line bg-surface">
      <section aria-label="Status" className="flex flex-wrap items-center gap-x-4 gap-y-1 px-3 py-1.5 text-xs">
        <span className="flex items-center gap-1.5">
          <span
            aria-hidden="true"
            className={`h-2 w-2 rounded-full ${socket.state === 'connected' ? 'bg-status-succeeded' : 'bg-status-failed'}`}
          />
          Socket: <strong data-socket-state={socket.state}>{socketText}</strong>
        </span>
        {unreachable && <span className="text-status-failed">Brain unreachable</span>}
        {latch && (
          <span className="flex items-center gap-1" data-latched={latch.latched}>
            <span aria-hidden="true" className={`h-2 w-2 rounded-full ${latch.latched ? 'bg-status-failed' : 'bg-status-succeeded'}`} />
            Software stop: <strong>{latch.latched ? 'latched' : 'clear'}</strong>
          </span>
        )}
        {ready && 'manipulation' in ready.data.mcp_servers && <HoldingChip />}
        {ready &&
          Object.entries(ready.data.mcp_servers).map(([name, state]) => (
            <span key={name} className="flex items-center gap-1" title={`${name}: ${state}`}>
              <span aria-hidden="true" className={`h-2 w-2 rounded-full ${SERVER_TONE[state]}`} />
              {name} <span className="sr-only text-muted lg:not-sr-only">{state}</span>
            </span>
          ))}
        {ready && (
          <span className="ml-auto text-muted" data-testid="understanding">
            planner{' '}
            <strong
              className={ready.data.planner_state === 'degraded' ? 'text-status-failed' : 'text-fg'}
              title={ready.data.planner ?? undefined}
            >
              {ready.data.planner_understanding ?? ready.data.planner ?? 'off'}
            </strong>{' '}
            · chat{' '}
            <strong className="text-fg" title={ready.data.llm}>
              {ready.data.llm_understanding ?? ready.data.llm}
            </strong>{' '}
            {recognizer && (
              <>
                · voice{' '}
                <strong className="text-fg" data-testid="recognizer">
                  {recognizer}
                </strong>{' '}
              </>
            )}
            · deployment <strong className="text-fg">{ready.data.deployment}</strong>
          </span>
        )}
      </section>
    </footer>
  );
}
