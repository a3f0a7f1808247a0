import { apiGet, apiPost } from '@/lib/api-client';
import { emitWithAck, getSocket } from '@/lib/socket';
import type { ActivityLine } from '@/stores/missionStore';
import type { MissionPlanPayload } from '@/types/events';

interface MissionList {
  active: string | null;
}

type TraceEvent = Record<string, unknown> & { kind?: string; ts?: number };
export type MissionDetail = MissionPlanPayload & {
  instruction: string;
  summary: string;
  teaching: boolean;
  events: TraceEvent[];
};

const LOG_KINDS = new Set(['tool_call', 'task_event', 'reaction', 'say', 'user_turn']);

/** A trace record as an activity-log line (the trace is richer than the live feed). */
export function traceLine(event: TraceEvent): Omit<ActivityLine, 'key'> {
  const kind = (event.kind === 'tool_result' ? 'tool_call' : event.kind) as ActivityLine['kind'];
  const ts = typeof event.ts === 'number' ? event.ts : Date.now() / 1000;
  const text =
    event.kind === 'task_event'
      ? `${String(event.task_id ?? '')} ${String(event.type ?? '')}`.trim()
      : event.kind === 'tool_result'
        ? `${String(event.tool ?? 'tool')} → ${String(event.result ?? '').slice(0, 120)}`
        : String(event.text ?? event.name ?? JSON.stringify(event).slice(0, 120));
  return { kind: LOG_KINDS.has(kind) ? kind : 'tool_call', text, ts };
}

/** After a reload: the active mission (if any) as the brain holds it. */
export async function fetchActiveMission(): Promise<MissionDetail | null> {
  const list = await apiGet<MissionList>('/api/agent/missions?limit=1');
  if (!list.active) return null;
  return apiGet<MissionDetail>(`/api/agent/missions/${encodeURIComponent(list.active)}`);
}

/** stop_pipeline: safety stop (motion cancelled, vision skills stopped) with or without a mission. */
export async function stopPipeline(): Promise<void> {
  if (getSocket().connected) {
    try {
      await emitWithAck('stop_pipeline', null, 3000);
      return;
    } catch {
      /* fall through to REST */
    }
  }
  await apiPost('/api/chat/stop', {});
}
