import { render, screen, waitFor } from '@testing-library/react';
import userEvent from '@testing-library/user-event';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { useSafetyStore } from '@/stores/safetyStore';
import { SafetyBanner } from './SafetyBanner';

afterEach(() => {
  vi.unstubAllGlobals();
  useSafetyStore.setState({ latch: null });
});

describe('safety banner', () => {
  it('shows nothing while the stop is clear', () => {
    useSafetyStore.setState({ latch: { latched: false } });
    render(<SafetyBanner />);
    expect(screen.queryByRole('region', { name: 'Safety stop' })).toBeNull();
  });

  it('says who latched it, why, and that the hardware e-stop remains required', () => {
    useSafetyStore.setState({ latch: { latched: true, since: 1, by: 'alice', reason: 'person in the corridor' } });
    render(<SafetyBanner />);
    const banner = screen.getByRole('region', { name: 'Safety stop' });
    expect(banner).toHaveTextContent('Software stop latched');
    expect(banner).toHaveTextContent('by alice: person in the corridor');
    expect(banner).toHaveTextContent('hardware emergency stop remains required');
  });

  it('names the supervision alarms that latched the stop, in words, without codes', () => {
    useSafetyStore.setState({
      latch: {
        latched: true,
        since: 1,
        by: "the robot's supervision",
        reason: 'another program is publishing on the motion lock of my navigation',
        alarms: [
          { server: 'navigation', code: 'LOCK_TOPIC_SHARED', detail: 'A second node publishes the lock.', at: 1 },
          { server: 'navigation', code: 'POSE_TOPIC_SHARED', detail: 'A second node publishes /amcl_pose.', at: 2 },
        ],
      },
    });
    render(<SafetyBanner />);
    const banner = screen.getByRole('region', { name: 'Safety stop' });
    expect(banner).toHaveTextContent('another program is publishing on the motion lock of my navigation');
    const alarms = screen.getByRole('list', { name: 'Supervision alarms' });
    expect(alarms).toHaveTextContent('Another program publishes on the motion lock (base');
    expect(alarms).toHaveTextContent('A second node publishes the lock.');
    expect(alarms).toHaveTextContent("Another program publishes the robot's position");
    expect(banner).not.toHaveTextContent('LOCK_TOPIC_SHARED');
    expect(screen.getByRole('button', { name: 'Clear stop' })).toBeInTheDocument();
  });

  it('shows an active alarm even before the latch is known, without a clear button', () => {
    useSafetyStore.setState({
      latch: { latched: false, alarms: [{ server: 'manipulation', code: 'FOREIGN_HOLDER', detail: '', at: 1 }] },
    });
    render(<SafetyBanner />);
    expect(screen.getByRole('region', { name: 'Safety stop' })).toHaveTextContent('Supervision alarm');
    expect(screen.getByRole('list', { name: 'Supervision alarms' })).toHaveTextContent(
      'Another program renewed the safety lease (arm',
    );
    expect(screen.queryByRole('button', { name: 'Clear stop' })).toBeNull();
  });

  it('clears only after a confirmation that says why', async () => {
    const cleared = new Response(JSON.stringify({ latched: false }), { status: 200 });
    const fetchMock = vi.fn(async () => cleared);
    vi.stubGlobal('fetch', fetchMock);
    useSafetyStore.setState({ latch: { latched: true, by: 'alice', reason: 'stop' } });
    render(<SafetyBanner />);

    await userEvent.click(screen.getByRole('button', { name: 'Clear stop' }));
    expect(fetchMock).not.toHaveBeenCalled();
    const confirm = screen.getByRole('button', { name: 'Confirm clear stop' });
    expect(confirm).toBeDisabled();
    await userEvent.type(screen.getByLabelText('Why is it safe to move?'), 'corridor checked');
    await userEvent.click(confirm);

    await waitFor(() => expect(useSafetyStore.getState().latch?.latched).toBe(false));
    expect(fetchMock).toHaveBeenCalledWith(
      '/api/safety/clear',
      expect.objectContaining({ method: 'POST', body: JSON.stringify({ reason: 'corridor checked' }) }),
    );
  });
});
