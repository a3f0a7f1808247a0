import { apiGet } from '@/lib/api-client';

export interface MapLocation {
  name: string;
  description: string;
  x: number;
  y: number;
}

export interface LocationList {
  map: string;
  locations: MapLocation[];
}

export interface Pose {
  x: number;
  y: number;
  theta: number;
  at_location: string | null;
  moving: boolean;
  destination: string | null;
  /** No live pose from the robot base (its navigation stack stopped answering, or none yet). */
  stale?: boolean;
  pose_note?: string | null;
  /** The base came back somewhere else after a silence (a restart): the marker moved. */
  relocated?: { from: { x: number; y: number }; to: { x: number; y: number }; distance_m: number } | null;
}

export const fetchLocations = () => apiGet<LocationList>('/api/map/locations');
export const fetchPose = () => apiGet<Pose>('/api/map/pose');
