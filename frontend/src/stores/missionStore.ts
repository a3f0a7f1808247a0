import { create } from 'zustand';
import type {
  MissionEventPayload,
  MissionFinishedPayload,
  MissionPlanPayload,
  MissionStartedPayload,
  StepView,
} from '@/types/events';

export type StepStatus = NonNullable<StepView['status']>;
export type MissionState = MissionPlanPayload['state'];

export interface Step {
  id: string;
  title: string;
  tool: string | null;
  status: StepStatus;
  detail: string;
  taskId: string | null;
  /** First seen in the latest snapshot (replanning): animates in. */
  isNew: boolean;
}

export interface Mission {
  id: string;
  instruction: string;
  state: MissionState;
  steps: Step[];
  startedAt: number | null;
  endedAt: number | null;
  teaching: boolean;
}

export interface ActivityLine {
  key: number;
  kind: MissionEventPayload['kind'];
  text: string;
  ts: number;
}

/** The activity log keeps this many lines (a 30-minute mission must not grow the page). */
export const ACTIVITY_LIMIT = 200;
export const ACTIVE_STATES: ReadonlySet<MissionState> = new Set(['planning', 'running', 'paused', 'awaiting_approval']);

interface MissionStore {
  mission: Mission | null;
  activity: ActivityLine[];
  nextKey: number;
  started: (event: MissionStartedPayload) => void;
  applySnapshot: (snapshot: MissionPlanPayload) => void;
  addEvent: (event: MissionEventPayload) => void;
  finished: (event: MissionFinishedPayload) => void;
  rehydrate: (snapshot: MissionPlanPayload & { instruction: string; teaching?: boolean }, lines: Omit<ActivityLine, 'key'>[]) => void;
  clear: () => void;
}

function emptyMission(id: string): Mission {
  return { id, instruction: '', state: 'planning', steps: [], startedAt: null, endedAt: null, teaching: false };
}

function stepsFrom(snapshot: MissionPlanPayload, previous: Step[] | null): Step[] {
  const known = new Set((previous ?? []).map((s) => s.id));
  return (snapshot.steps ?? []).map((s) => ({
    id: s.id,
    title: s.title,
    tool: s.tool ?? null,
    status: s.status ?? 'pending',
    detail: s.detail ?? '',
    taskId: s.task_id ?? null,
    isNew: previous !== null && previous.length > 0 && !known.has(s.id),
  }));
}

function appendBounded(lines: ActivityLine[], line: ActivityLine): ActivityLine[] {
  const next = lines.length >= ACTIVITY_LIMIT ? lines.slice(lines.length - ACTIVITY_LIMIT + 1) : lines.slice();
  next.push(line);
  return next;
}

export const useMissionStore = create<MissionStore>()((set) => ({
  mission: null,
  activity: [],
  nextKey: 0,
  started: (event) =>
    set({
      mission: {
        ...emptyMission(event.mission_id),
        instruction: event.instruction,
        teaching: event.teaching ?? false,
        startedAt: event.started_at ?? Date.now() / 1000,
      },
      activity: [],
    }),
  // A snapshot replaces the plan (never patches it): the UI is exactly the brain's state.
  applySnapshot: (snapshot) =>
    set((state) => {
      const same = state.mission?.id === snapshot.mission_id ? state.mission : null;
      const base = same ?? emptyMission(snapshot.mission_id);
      return {
        mission: {
          ...base,
          state: snapshot.state,
          steps: stepsFrom(snapshot, same ? same.steps : null),
          startedAt: snapshot.started_at ?? base.startedAt,
          endedAt: snapshot.ended_at ?? base.endedAt,
        },
        activity: same ? state.activity : [],
      };
    }),
  addEvent: (event) =>
    set((state) => {
      if (state.mission && state.mission.id !== event.mission_id) return state;
      const line = { key: state.nextKey, kind: event.kind, text: event.text, ts: event.ts };
      return { activity: appendBounded(state.activity, line), nextKey: state.nextKey + 1 };
    }),
  finished: (event) =>
    set((state) => {
      if (!state.mission || state.mission.id !== event.mission_id) return state;
      return { mission: { ...state.mission, state: event.outcome, endedAt: state.mission.endedAt ?? Date.now() / 1000 } };
    }),
  // The REST snapshot may arrive after live events of the same mission: those are newer, so
  // keep their steps and lines and take only what snapshots lack (instruction, teaching).
  rehydrate: (snapshot, lines) =>
    set((state) => {
      const live = state.mission?.id === snapshot.mission_id ? state.mission : null;
      if (live) {
        const kept = state.activity.length > 0 ? state.activity : lines.slice(-ACTIVITY_LIMIT).map((l, i) => ({ ...l, key: state.nextKey + i }));
        return {
          mission: {
            ...live,
            instruction: snapshot.instruction,
            teaching: snapshot.teaching ?? live.teaching,
            steps: live.steps.length > 0 ? live.steps : stepsFrom(snapshot, null),
            startedAt: live.startedAt ?? snapshot.started_at ?? null,
          },
          activity: kept,
          nextKey: state.nextKey + kept.length,
        };
      }
      const mission: Mission = {
        ...emptyMission(snapshot.mission_id),
        instruction: snapshot.instruction,
        teaching: snapshot.teaching ?? false,
        state: snapshot.state,
        steps: stepsFrom(snapshot, null),
        startedAt: snapshot.started_at ?? null,
        endedAt: snapshot.ended_at ?? null,
      };
      const kept = lines.slice(-ACTIVITY_LIMIT);
      return {
        mission,
        activity: kept.map((l, i) => ({ ...l, key: state.nextKey + i })),
        nextKey: state.nextKey + kept.length,
      };
    }),
  clear: () => set({ mission: null, activity: [] }),
}));
