import { render, screen, waitFor, within } from '@testing-library/react';
import userEvent from '@testing-library/user-event';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { useApprovalStore } from '@/stores/approvalStore';
import { ApprovalCards } from './ApprovalCard';

const APPROVAL = {
  approval_id: 'ap-1',
  mission_id: 'm-1',
  step_id: 's1',
  tool: 'navigation.navigate_to',
  arguments: { location: 'kitchen' },
  reason: 'drives the robot',
  expires_at: Date.now() / 1000 + 60,
};

afterEach(() => {
  vi.unstubAllGlobals();
  useApprovalStore.setState({ pending: [] });
});

describe('approval card', () => {
  it('shows the exact call, its step and why', () => {
    useApprovalStore.setState({ pending: [APPROVAL] });
    render(<ApprovalCards missionId="m-1" />);
    const card = screen.getByRole('region', { name: 'Approval' });
    expect(card).toHaveTextContent('navigation.navigate_to');
    expect(card).toHaveTextContent('{"location":"kitchen"}');
    expect(card).toHaveTextContent('s1');
    expect(card).toHaveTextContent('drives the robot');
  });

  it('shows only the approvals of this mission', () => {
    useApprovalStore.setState({ pending: [{ ...APPROVAL, mission_id: 'm-2' }] });
    render(<ApprovalCards missionId="m-1" />);
    expect(screen.queryByRole('region', { name: 'Approval' })).toBeNull();
  });

  it.each([
    ['Approve', 'approve'],
    ['Deny', 'deny'],
  ])('%s posts the decision for that approval and removes the card', async (button, decision) => {
    const fetchMock = vi.fn(async () => new Response(JSON.stringify({ approval_id: 'ap-1', decision }), { status: 200 }));
    vi.stubGlobal('fetch', fetchMock);
    useApprovalStore.setState({ pending: [APPROVAL] });
    render(<ApprovalCards missionId="m-1" />);
    await userEvent.click(within(screen.getByRole('region', { name: 'Approval' })).getByRole('button', { name: button }));
    await waitFor(() => expect(useApprovalStore.getState().pending).toEqual([]));
    expect(fetchMock).toHaveBeenCalledWith(
      '/api/agent/approvals/ap-1',
      expect.objectContaining({ method: 'POST', body: JSON.stringify({ decision }) }),
    );
  });

  it('keeps the card when the brain refuses the answer (expired, replayed)', async () => {
    vi.stubGlobal('fetch', vi.fn(async () => new Response(JSON.stringify({ detail: 'expired' }), { status: 410 })));
    useApprovalStore.setState({ pending: [APPROVAL] });
    render(<ApprovalCards missionId="m-1" />);
    await userEvent.click(screen.getByRole('button', { name: 'Approve' }));
    await waitFor(() => expect(screen.getByRole('button', { name: 'Approve' })).toBeEnabled());
    expect(useApprovalStore.getState().pending).toHaveLength(1);
  });
});
