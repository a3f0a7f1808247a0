import { apiGet } from '@/lib/api-client';

export interface MapLocation {
  name: string;
  /** How people name it ("Alice's desk"); the map id (`name`) is never shown. */
  label?: string;
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

export interface Box {
  x0: number;
  y0: number;
  x1: number;
  y1: number;
}

/** The robot's own map (/map and its costmap), as navigation serves it for a display. */
export type Floor =
  | { available: false; detail?: string }
  | {
      available: true;
      resolution: number;
      origin: { x: number; y: number };
      width: number;
      height: number;
      bounds: Box;
      /** base64 PNG masks, white = set, top row = the map's largest y */
      walls_png: string;
      unknown_png: string;
      /** free on the map, blocked on the robot's costmap (a closed door it saw) */
      blocked: Box[];
      version: string;
    };

export interface Plan {
  frame: string;
  points: [number, number][];
  destination: string | null;
}

export const fetchFloor = () => apiGet<Floor>('/api/map/floor');
export const fetchPlan = () => apiGet<Plan>('/api/map/plan');
