import { apiGet } from '@/lib/api-client';

/** Where the robot stood when it first saw something (map metres, yaw in radians). */
export interface RobotPose {
  x: number;
  y: number;
  yaw: number;
  map: string | null;
}

/** One row of GET /api/history: an interval in which a skill kept seeing a label. */
export interface Sighting {
  id: string;
  label: string;
  skill: string | null;
  first_seen: string; // ISO 8601 (UTC)
  last_seen: string | null;
  ago: string | null; // "2 min ago", from the memory server's clock
  t: number | null;
  seen_for: string | null;
  place: string | null;
  pose: RobotPose | null;
  score: number | null;
  count: number | null;
}

export interface History {
  since: string | null;
  now: string | null;
  count: number;
  truncated: boolean;
  sightings: Sighting[];
}

export const HISTORY_SINCE = '-24h';
export const HISTORY_LIMIT = 50;

export const fetchHistory = (since = HISTORY_SINCE, limit = HISTORY_LIMIT) =>
  apiGet<History>(`/api/history?${new URLSearchParams({ since, limit: String(limit) }).toString()}`);

/** The local wall-clock time of an ISO instant, e.g. "14:03:12". */
export function localClock(iso: string): string {
  return new Date(iso).toLocaleTimeString([], { hour: '2-digit', minute: '2-digit', second: '2-digit', hour12: false });
}
