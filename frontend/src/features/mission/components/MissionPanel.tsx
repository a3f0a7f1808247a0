import { Button } from '@/components/ui/Button';
import { ApprovalCards } from '@/features/approvals/components/ApprovalCard';
import { StatusChip } from '@/components/ui/StatusChip';
import { sendMessage } from '@/features/chat/api/chat';
import { stopPipeline } from '@/features/mission/api/missions';
import { formatElapsed, useNow } from '@/lib/useNow';
import { ACTIVE_STATES, useMissionStore, type Mission } from '@/stores/missionStore';
import { useToastStore } from '@/stores/toastStore';
import { ActivityLog } from './ActivityLog';
import { PlanList } from './PlanStep';

function act(action: () => Promise<void>, what: string) {
  action().catch((err: unknown) => useToastStore.getState().push('error', `${what} failed: ${String(err)}`));
}

function Elapsed({ mission }: { mission: Mission }) {
  const now = useNow(mission.endedAt === null);
  if (mission.startedAt === null) return null;
  const seconds = (mission.endedAt ?? now) - mission.startedAt;
  return (
    <span className="font-mono text-xs text-muted" aria-label={`elapsed ${formatElapsed(seconds)}`}>
      {formatElapsed(seconds)}
    </span>
  );
}

function PausedBanner() {
  return (
    <div role="alert" className="flex flex-wrap items-center gap-2 border-b border-line bg-warn-bg px-3 py-2">
      <strong className="flex-1 text-sm">Paused — continue or abort?</strong>
      <Button variant="primary" onClick={() => act(() => sendMessage('continue'), 'Continue')}>
        Continue
      </Button>
      <Button onClick={() => act(() => sendMessage('abort'), 'Abort')}>Abort</Button>
    </div>
  );
}

/** Spec §11.2: header, paused banner, the plan timeline, the activity log. */
export function MissionPanel() {
  const mission = useMissionStore((s) => s.mission);
  const activity = useMissionStore((s) => s.activity);
  const active = mission !== null && ACTIVE_STATES.has(mission.state);
  if (!mission || !active) {
    return (
      <>
        <ApprovalCards missionId={null} />
        <section aria-label="Mission" className="rounded-lg border border-dashed border-line px-3 py-2 text-sm text-muted">
          No mission running. Ask the robot to do something, e.g. “Please fetch the package from the mailroom and bring it to reception.”
        </section>
      </>
    );
  }
  return (
    <section aria-label="Mission" className="overflow-hidden rounded-lg border border-line bg-surface">
      <header className="flex flex-wrap items-center gap-2 border-b border-line px-3 py-2">
        <h2 className="min-w-0 flex-1 truncate text-sm font-semibold" title={mission.instruction}>
          {mission.instruction || 'Mission'}
        </h2>
        {mission.teaching && <span className="text-xs text-accent">teaching</span>}
        <StatusChip state={mission.state} />
        <Elapsed mission={mission} />
        <Button variant="danger" onClick={() => act(stopPipeline, 'Stop mission')}>
          Stop mission
        </Button>
      </header>
      {mission.state === 'paused' && <PausedBanner />}
      <ApprovalCards missionId={mission.id} />
      <div className="px-3 py-2">
        {mission.steps.length === 0 ? (
          <p className="text-sm text-muted">Planning…</p>
        ) : (
          <PlanList steps={mission.steps} label="Plan" />
        )}
      </div>
      <ActivityLog lines={activity} />
    </section>
  );
}
