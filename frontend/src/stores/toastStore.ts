import { create } from 'zustand';

export interface Toast {
  id: number;
  tone: 'info' | 'success' | 'error';
  text: string;
}

interface ToastStore {
  toasts: Toast[];
  nextId: number;
  push: (tone: Toast['tone'], text: string) => void;
  dismiss: (id: number) => void;
}

export const useToastStore = create<ToastStore>()((set) => ({
  toasts: [],
  nextId: 1,
  push: (tone, text) =>
    set((s) => ({ toasts: [...s.toasts.slice(-4), { id: s.nextId, tone, text }], nextId: s.nextId + 1 })),
  dismiss: (id) => set((s) => ({ toasts: s.toasts.filter((t) => t.id !== id) })),
}));
