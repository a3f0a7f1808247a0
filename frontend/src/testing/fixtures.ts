import type { MissionPlanPayload } from '@/types/events';

/** A snapshot with one step in each of the five states (spec 002 §13). */
export const fiveStates: MissionPlanPayload = {
  mission_id: 'm-abc123',
  state: 'running',
  started_at: 1_700_000_000,
  steps: [
    { id: 's1', title: 'Drive to the mailroom', tool: 'navigation.navigate_to', status: 'failed', detail: 'DOOR_CLOSED: the mailroom door is closed', task_id: 'nav-1' },
    { id: 's1b', title: 'Drive to corridor B', tool: 'navigation.navigate_to', status: 'succeeded', detail: 'arrived', task_id: 'nav-2' },
    { id: 's1c', title: 'Drive to the mailroom via the east entrance', tool: 'navigation.navigate_to', status: 'running', detail: 'ETA 12 s · 40 %', task_id: 'nav-3' },
    { id: 's2', title: 'Find the package', tool: 'skill_control.instantiate_skill', status: 'pending', detail: '', task_id: null },
    { id: 's9', title: 'Ask at reception', tool: null, status: 'skipped', detail: 'removed from the plan', task_id: null },
  ],
};
