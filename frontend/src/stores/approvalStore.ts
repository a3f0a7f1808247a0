import { create } from 'zustand';
import type { ApprovalRequestedPayload } from '@/types/events';

interface ApprovalStore {
  /** Approvals the brain waits for (a snapshot from REST replaces; events add/remove). */
  pending: ApprovalRequestedPayload[];
  load: (pending: ApprovalRequestedPayload[]) => void;
  requested: (approval: ApprovalRequestedPayload) => void;
  resolved: (approvalId: string) => void;
}

export const useApprovalStore = create<ApprovalStore>()((set) => ({
  pending: [],
  load: (pending) => set({ pending }),
  requested: (approval) =>
    set((s) => ({ pending: [...s.pending.filter((p) => p.approval_id !== approval.approval_id), approval] })),
  resolved: (approvalId) => set((s) => ({ pending: s.pending.filter((p) => p.approval_id !== approvalId) })),
}));
