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
}

export const fetchLocations = () => apiGet<LocationList>('/api/map/locations');
export const fetchPose = () => apiGet<Pose>('/api/map/pose');
