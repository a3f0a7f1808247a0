import { apiGet } from '@/lib/api-client';

export interface DetectionRow {
  label: string;
  score: number | null;
  skill: string;
  age_s: number | null;
  stale: boolean;
}

export interface Detections {
  ts: number;
  mode: string | null;
  scene: string | null;
  /** how old the scene description is (the describer runs at its own rate) */
  scene_age_s?: number | null;
  detections: DetectionRow[];
}

export const fetchDetections = () => apiGet<Detections>('/api/camera/detections');

/** The latest frame as a blob; a 503 JSON (camera offline) becomes an Error with its detail. */
export async function fetchFrame(signal?: AbortSignal): Promise<Blob> {
  const response = await fetch('/api/camera/frame', { cache: 'no-store', signal });
  if (!response.ok) {
    let detail = `HTTP ${response.status}`;
    try {
      detail = String(((await response.json()) as { detail?: string }).detail ?? detail);
    } catch {
      /* not JSON */
    }
    throw new Error(detail);
  }
  return response.blob();
}
