import { create } from 'zustand';
import type { Sighting } from '@/features/history/api/history';

interface HistoryStore {
  /** The sighting the operator chose in the History panel: the map marks where the robot was. */
  selected: Sighting | null;
  select: (sighting: Sighting | null) => void;
}

export const useHistoryStore = create<HistoryStore>()((set) => ({
  selected: null,
  select: (selected) => set({ selected }),
}));
