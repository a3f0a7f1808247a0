import { useState } from 'react';
import { Button } from '@/components/ui/Button';
import { useNow } from '@/lib/useNow';
import { useApprovalStore } from '@/stores/approvalStore';
import { useToastStore } from '@/stores/toastStore';
import type { ApprovalRequestedPayload } from '@/types/events';
import { decideApproval } from '../api/approvals';

/** One call the robot waits to make: the tool, its exact arguments, the step and why. */
export function ApprovalCard({ approval }: { approval: ApprovalRequestedPayload }) {
  const now = useNow(true);
  const [busy, setBusy] = useState(false);
  const left = Math.max(0, Math.round(approval.expires_at - now));
  const decide = async (decision: 'approve' | 'deny') => {
    setBusy(true);
    try {
      await decideApproval(approval.approval_id, decision);
      useApprovalStore.getState().resolved(approval.approval_id);
    } catch (err: unknown) {
      useToastStore.getState().push('error', `${decision === 'approve' ? 'Approve' : 'Deny'} failed: ${String(err)}`);
    } finally {
      setBusy(false);
    }
  };
  return (
    <section
      aria-label="Approval"
      data-approval-id={approval.approval_id}
      className="m-3 rounded-lg border-2 border-accent bg-raised px-3 py-2 text-sm"
    >
      <h3 className="font-semibold">The robot asks for your approval</h3>
      <dl className="mt-1 grid grid-cols-[auto_1fr] gap-x-3 gap-y-0.5">
        <dt className="text-muted">Tool</dt>
        <dd>
          <code>{approval.tool}</code>
        </dd>
        <dt className="text-muted">Arguments</dt>
        <dd>
          <code className="break-all">{JSON.stringify(approval.arguments)}</code>
        </dd>
        {approval.step_id && (
          <>
            <dt className="text-muted">Step</dt>
            <dd>{approval.step_id}</dd>
          </>
        )}
        <dt className="text-muted">Why</dt>
        <dd>{approval.reason}</dd>
      </dl>
      <div className="mt-2 flex items-center gap-2">
        <Button variant="primary" disabled={busy} onClick={() => void decide('approve')}>
          Approve
        </Button>
        <Button variant="danger" disabled={busy} onClick={() => void decide('deny')}>
          Deny
        </Button>
        <span className="text-xs text-muted" aria-live="off">
          denied automatically in {left} s; you can also say “yes” or “no”
        </span>
      </div>
    </section>
  );
}

/** The approvals of one mission (or, without one, those of the fast path). */
export function ApprovalCards({ missionId }: { missionId: string | null }) {
  const pending = useApprovalStore((s) => s.pending);
  const mine = pending.filter((p) => (p.mission_id ?? null) === missionId);
  return (
    <>
      {mine.map((approval) => (
        <ApprovalCard key={approval.approval_id} approval={approval} />
      ))}
    </>
  );
}
