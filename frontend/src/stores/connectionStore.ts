import { create } from 'zustand';

export type SocketState = 'connecting' | 'connected' | 'reconnecting' | 'disconnected';

interface ConnectionStore {
  state: SocketState;
  attempts: number;
  setState: (state: SocketState, attempts?: number) => void;
}

export const useConnectionStore = create<ConnectionStore>()((set) => ({
  state: 'connecting',
  attempts: 0,
  setState: (state, attempts) => set((s) => ({ state, attempts: attempts ?? s.attempts })),
}));
