import { apiGet } from '@/lib/api-client';

/** Where the robot stood when it first saw something (map metres, yaw in radians). */
export interface RobotPose {
  x: number;
  y: number;
  yaw: number;
  map: string | null;
}

/** One row of GET /api/history: an interval in which the robot kept seeing a label at a place
 * (`skill` is the one whose data the row holds; `skills` every skill that saw it then). */
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
  skills?: (string | null)[];
}

export interface History {
  since: string | null;
  now: string | null;
  count: number;
  truncated: boolean;
  sightings: Sighting[];
}

/** A window the History panel can show: `since` as the brain's API takes it (the episodic
 *  server resolves it: "00:00" is midnight today in the site's time zone). */
export interface HistoryWindow {
  id: string;
  label: string; // the choice, "Last hour"
  span: string; // completes "Nothing seen …" / "the newest 50 of …"
  since: string;
}

/** What the panel shows first. */
export const DEFAULT_WINDOW: HistoryWindow = { id: '24h', label: 'Last 24 hours', span: 'in the last 24 hours', since: '-24h' };
export const HISTORY_WINDOWS: readonly HistoryWindow[] = [
  { id: '1h', label: 'Last hour', span: 'in the last hour', since: '-1h' },
  { id: 'today', label: 'Today', span: 'today', since: '00:00' },
  DEFAULT_WINDOW,
  { id: '7d', label: 'Last 7 days', span: 'in the last 7 days', since: '-7d' },
];
export const HISTORY_LIMIT = 50;

export const fetchHistory = (since: string, limit = HISTORY_LIMIT) =>
  apiGet<History>(`/api/history?${new URLSearchParams({ since, limit: String(limit) }).toString()}`);

/** The local wall-clock time of an ISO instant, e.g. "14:03:12". */
export function localClock(iso: string): string {
  return new Date(iso).toLocaleTimeString([], { hour: '2-digit', minute: '2-digit', second: '2-digit', hour12: false });
}
