import { apiGet } from '@/lib/api-client';

/** What the robot's gripper holds, as the arm's server reports it (`GET /api/robot/held`). */
export interface Held {
  /** false until the robot reported what it holds */
  known: boolean;
  holding: boolean | null;
  label: string | null;
  /** the pick/place running now, if any */
  busy?: boolean;
  action?: 'pick' | 'place' | 'release' | null;
}

export const fetchHeld = () => apiGet<Held>('/api/robot/held');
