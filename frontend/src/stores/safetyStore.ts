import { create } from 'zustand';
import type { SafetyStatePayload } from '@/types/events';

interface SafetyStore {
  /** The latched software stop as the brain holds it (null until first known). */
  latch: SafetyStatePayload | null;
  setLatch: (latch: SafetyStatePayload) => void;
}

export const useSafetyStore = create<SafetyStore>()((set) => ({
  latch: null,
  setLatch: (latch) => set({ latch }),
}));
