import type { MissionState, StepStatus } from '@/stores/missionStore';

/** Same colour language for step statuses and mission states (semantic tokens only). */
export const STATUS_TEXT: Record<StepStatus, string> = {
  pending: 'text-status-pending',
  running: 'text-status-running',
  succeeded: 'text-status-succeeded',
  failed: 'text-status-failed',
  skipped: 'text-status-skipped',
};

const STATE_TO_STATUS: Record<MissionState, StepStatus> = {
  planning: 'pending',
  running: 'running',
  paused: 'skipped',
  awaiting_approval: 'pending',
  succeeded: 'succeeded',
  failed: 'failed',
  cancelled: 'skipped',
};

export function StatusChip({ state }: { state: MissionState }) {
  const tone = STATUS_TEXT[STATE_TO_STATUS[state]];
  return (
    <span
      data-mission-state={state}
      className={`inline-flex items-center rounded-full border border-current px-2 py-0.5 text-xs font-semibold uppercase tracking-wide ${tone}`}
    >
      {state.replace('_', ' ')}
    </span>
  );
}
