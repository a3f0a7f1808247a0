import { apiGet, apiPost } from '@/lib/api-client';
import type { ApprovalRequestedPayload } from '@/types/events';

export const fetchApprovals = () => apiGet<ApprovalRequestedPayload[]>('/api/agent/approvals');

export const decideApproval = (approvalId: string, decision: 'approve' | 'deny') =>
  apiPost<{ approval_id: string; decision: string }>(`/api/agent/approvals/${encodeURIComponent(approvalId)}`, {
    decision,
  });
